"""Cell files read as strictly as model files (issue 47, cause 6): a cell naming itself or two cells
naming each other, an empty ``mount:``, a mirror or shear frame rotation, each a one-line ModelError
naming the file and the key (was a RecursionError, an internal error, a mirrored mount accepted)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.core.errors import ModelError

HEAD = "units: {length: mm, angle: deg}\n"
TRACK = "track: {direction: [1, 0, 0], limits: [0, 6000]}\n"
AXES = "  axes: [{type: revolute, axis: [1, 0, 0], origin: [0, 0, 900], limits: [-90, 90]}]\n"


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(HEAD + text)
    return path


def test_a_cell_whose_robot_is_itself_is_refused_naming_the_loop(tmp_path):
    path = _write(tmp_path, "self.yaml", "robot: self.yaml\n" + TRACK)
    for load in (rc.load_cell, rc.load_model):
        with pytest.raises(ModelError, match=r"self\.yaml.*names itself \(self\.yaml -> self\.yaml\)"):
            load(str(path))


def test_two_cells_naming_each_other_are_refused_naming_the_loop(tmp_path):
    a = _write(tmp_path, "a.yaml", "robots: {left: {model: b.yaml}}\n")
    _write(tmp_path, "b.yaml", "robots: {left: {model: a.yaml}}\n")
    with pytest.raises(ModelError, match=r"names itself \(a\.yaml -> b\.yaml -> a\.yaml\)"):
        rc.load_cell(a)
    out = tmp_path / "o.urdf"
    assert main(["--quiet", "export", str(a), "--urdf", str(out)]) == 2 and not out.exists()


def test_the_same_model_file_named_twice_is_no_loop(tmp_path):
    """Two arms of one model file (siblings, not a loop) read fine."""
    rc.Robot.from_catalog("abb_irb2600").save(tmp_path / "arm.yaml")
    path = _write(tmp_path, "cell.yaml", "robots: {left: {model: arm.yaml}, right: {model: arm.yaml, "
                                         "base: {xyz: [3000, 0, 0]}}}\n")
    assert list(rc.load_cell(path).arms) == ["left", "right"]


def test_an_empty_mount_is_no_mount_as_an_empty_base_is(tmp_path):
    """``mount:`` left empty (was an internal error): the carriage carries the arm's base as it is,
    the same chain as without the key (a model file's empty ``base:`` is no base too)."""
    empty = _write(tmp_path, "empty.yaml", "robot: abb_irb2600\n" + TRACK + "mount:\n")
    none = _write(tmp_path, "none.yaml", "robot: abb_irb2600\n" + TRACK)
    q = np.zeros((1, 7))
    q[0, 0] = 1.2
    np.testing.assert_allclose(rc.load_model(str(empty)).fk(q), rc.load_model(str(none)).fk(q))


@pytest.mark.parametrize("rotation, fault", [("[[1, 0, 0], [0, 1, 0], [0, 0, -1]]", "a mirror"),
                                             ("[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]", "not orthonormal"),
                                             ("[[2, 0, 0], [0, 2, 0], [0, 0, 2]]", "not orthonormal")])
@pytest.mark.parametrize("where, text", [
    ("mount", "robot: abb_irb2600\n" + TRACK + "mount: {xyz: [0, 0, 500], rotation: ROT}\n"),
    ("positioner.mount", "robot: abb_irb2600\npositioner:\n  unit: STN1\n  mount: {rotation: ROT}\n" + AXES),
    ("positioner.plate", "positioner:\n  unit: STN1\n  plate: {rotation: ROT}\n" + AXES),
    ("robots.left.base", "robots: {left: {model: abb_irb2600, base: {rotation: ROT}}}\n"),
    ("robots.left.flange", "robots: {left: {model: abb_irb2600, flange: {rotation: ROT}}}\n"),
    ("base", "name: m\nopw: {a1: 150, a2: -115, b: 0, c1: 445, c2: 700, c3: 795, c4: 85, "
             "offsets: [0, 0, -90, 0, 0, 0], signs: [1, 1, 1, 1, 1, 1]}\nbase: {rotation: ROT}\n"),
])
def test_a_mirror_or_shear_frame_is_refused_like_a_models_base(tmp_path, where, text, rotation, fault):
    """Every frame of a cell file (mount, plate, base, flange) refused as a model file's base and
    tool are, by the same check, naming the key (a mirrored positioner mount was accepted)."""
    path = _write(tmp_path, "cell.yaml", text.replace("ROT", rotation))
    load = rc.load_model if where == "base" else rc.load_cell
    with pytest.raises(ModelError, match=rf"cell\.yaml: {where}\.rotation is {fault}"):
        load(str(path))


def test_a_robot_given_a_mirrored_base_is_refused_by_the_same_check():
    arm = rc.Robot.from_catalog("abb_irb2600")
    with pytest.raises(ModelError, match="base rotation is a mirror"):
        arm.with_frames(base=np.diag([1.0, 1.0, -1.0, 1.0]))


def test_a_model_name_too_long_for_a_file_is_refused_not_an_os_error(tmp_path):
    """``robot: kuka_kr1111...`` (thousands of characters, as the fuzzing made it): 'File name too
    long' from the file system was an internal error; now no file, an unknown catalog name."""
    long = "kuka_kr" + "1" * 3000
    path = _write(tmp_path, "track.yaml", f"robot: {long}\n" + TRACK)
    with pytest.raises(ModelError, match=r"track\.yaml: .*kuka_kr1111"):
        rc.load_cell(path)
    out = tmp_path / "o.urdf"
    assert main(["--quiet", "export", long, "--urdf", str(out)]) == 2 and not out.exists()


def test_a_positioner_column_of_thousands_of_digits_is_refused_with_its_key(tmp_path):
    path = _write(tmp_path, "cell.yaml",
                  f"positioner:\n  unit: STN1\n  columns: [e{'1' * 5000}]\n" + AXES)
    with pytest.raises(ModelError, match=r"cell\.yaml: STN1: columns .*expected 1 distinct names e1, e2"):
        rc.load_cell(path)


@pytest.mark.parametrize("text, match", [
    ("robot: abb_irb2600\n" + TRACK + "mount: {xyz: [0, 0, 0.5]}\n",
     r"mount: 0\.5 mm is too small for an offset in a cell .*metres \(0\.5 m = 500 mm\)"),
    ("robots: {left: {model: abb_irb2600}, right: {model: abb_irb2600, base: {xyz: [0.003, 0.0005, 0]}}}\n",
     r"robots\.right\.base: 0\.003 mm is too small"),
    ("robot: abb_irb2600\npositioner:\n  unit: STN1\n  mount: {xyz: [1.5, 0, 0]}\n" + AXES,
     r"positioner\.mount: 1\.5 mm is too small .*metres"),
])
def test_a_placement_in_another_unit_than_the_files_is_refused(tmp_path, text, match):
    """A 500 mm riser written 0.5 in a cell file in mm was accepted (the flange 0.5 m off): a body's
    placement is checked against the file's unit as a model file's lengths are."""
    path = _write(tmp_path, "cell.yaml", text)
    with pytest.raises(ModelError, match=match):
        rc.load_cell(path)


def test_a_placement_in_millimetres_in_a_file_in_metres_is_refused(tmp_path):
    path = tmp_path / "cell.yaml"
    path.write_text("units: {length: m, angle: deg}\nrobots: {left: {model: abb_irb2600}, right: "
                    "{model: abb_irb2600, base: {xyz: [3000, 0, 0]}}}\n")
    with pytest.raises(ModelError, match=r"robots\.right\.base: 3000 m is too large .*millimetres"):
        rc.load_cell(path)


def test_an_arm_on_a_riser_without_a_track_is_a_one_arm_cell(tmp_path):
    """``robot:`` with a ``mount:`` and no track (an arm on a 500 mm riser) was refused as a model
    file with unknown keys; it is a work cell of one arm, and as a robot its base is the mount."""
    path = tmp_path / "riser.yaml"
    path.write_text("units: {length: mm, angle: deg}\nrobot: abb_irb2600\nmount: {xyz: [0, 0, 500]}\n")
    cell = rc.load_cell(path)
    assert list(cell.arms) == ["arm"] and not cell.positioners
    assert np.allclose(rc.Robot.load(path).base[:3, 3], [0, 0, 0.5])
