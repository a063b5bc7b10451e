"""Injection into outputs through a model's name (tests/attacks.py): every writer's output keeps
the structure it has with a harmless name, or the command refuses in one line. A seeded sample in
the default suite, every hostile name in the slow run (``python tests/attacks.py``)."""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET

import pytest
from attacks import HOSTILE, attack, cli, model_with_name

import robocal as rc
from robocal.kinematics.urdf import to_urdf

FAST = ["a\nb", "<script>alert(1)</script>"]  # the rest in the slow run (each ~7 s)


@pytest.mark.parametrize("name", ["a\x00b", "a\x1b[31mb", "a\x0bb\x0cc"])
def test_a_control_character_in_a_name_leaves_the_urdf_well_formed(tmp_path, name):
    """``export --urdf`` of a model named with a control character wrote, exit 0, a URDF no XML
    parser reads (XML 1.0 holds no such character, not even as a reference)."""
    model = model_with_name(tmp_path, name)
    code, _, err = cli(["--quiet", "export", model, "--urdf", tmp_path / "m.urdf"])
    assert code == 0, err
    assert "?" in ET.parse(tmp_path / "m.urdf").getroot().get("name")


def test_a_name_with_a_line_end_reads_back_from_the_urdf():
    robot = dataclasses.replace(rc.Robot.from_catalog("ur5e"), name="line one\nline two\tand a tab")
    assert ET.fromstring(to_urdf(robot)).get("name") == robot.name


@pytest.mark.parametrize("name", FAST)
def test_hostile_names_keep_every_output_whole(tmp_path, name):
    assert not attack(tmp_path, name)


@pytest.mark.slow
@pytest.mark.parametrize("name", [h for h in HOSTILE if h not in FAST])
def test_every_hostile_name_keeps_every_output_whole(tmp_path, name):
    assert not attack(tmp_path, name)


def _evaluate_into(tmp_path, out) -> tuple[int, str]:
    model = tmp_path / "m.yaml"
    rc.Robot.from_catalog("abb_irb2600").save(model)
    data = tmp_path / "d.csv"
    from robocal.data.simulate import simulate_tracker
    simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 20, seed=1).data.save(data)
    code, _, err = cli(["--quiet", "evaluate", model, data, "--fit-frame", "--json", out])
    return code, err


@pytest.mark.parametrize("make", ["fifo", "link to a device", "link to a file"])
def test_an_output_that_is_no_regular_file_is_refused_and_left_alone(tmp_path, make):
    """Run as root, ``--json /dev/stdout`` and ``--json /dev/full`` replaced the link and the device
    with a regular file (exit 0): the atomic write renames a new file over the name given."""
    import os

    out = tmp_path / "out.json"
    target = tmp_path / "target.json"
    if make == "fifo":
        os.mkfifo(out)
    elif make == "link to a device":
        out.symlink_to("/dev/null")
    else:
        target.write_text("{}")
        out.symlink_to(target)
    code, err = _evaluate_into(tmp_path, out)
    assert code == 2 and ("not a regular file" in err or "symbolic link" in err), err
    assert (out.is_fifo() if make == "fifo" else out.is_symlink())
    assert make != "link to a file" or target.read_text() == "{}"


@pytest.mark.parametrize("source", ["/dev/zero", "fifo"])
@pytest.mark.parametrize("role", ["model", "data"])
def test_an_input_that_is_a_device_or_a_pipe_is_refused_at_once(tmp_path, source, role):
    """``evaluate m.yaml /dev/zero`` read until killed (a timeout of 20 s), the model from /dev/zero
    until memory ran out, a FIFO with no writer forever."""
    import os
    import signal

    if source == "fifo":
        source = tmp_path / "in.fifo"
        os.mkfifo(source)
    model = tmp_path / "m.yaml"
    rc.Robot.from_catalog("abb_irb2600").save(model)
    from robocal.data.simulate import simulate_tracker
    data = tmp_path / "d.csv"
    simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 20, seed=1).data.save(data)
    argv = ["--quiet", "evaluate", source if role == "model" else model, source if role == "data" else data,
            "--json", tmp_path / "o.json"]

    def hung(*_):
        raise TimeoutError
    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(20)
    try:
        code, _, err = cli(argv)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert code == 2 and "not a regular file" in err and not (tmp_path / "o.json").exists(), err
