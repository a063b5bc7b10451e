"""What the user gives against what the model or the program holds: a --tool / --frame compared
with the program's own data in every language that carries them (robocal.programs.overrides)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.cli import main
from robocal.core.magnitudes import CALIBRATED_TCP_MM
from robocal.data.simulate import perturbed
from robocal.kinematics.transforms import make_transform
from robocal.programs import filter_program
from robocal.programs.registry import dialect_named
from robocal.programs.simulate import write_program
from robocal.programs.source import ProgramText

NOMINAL = rc.Robot.from_catalog("kuka_kr16_2")
CALIBRATED = perturbed(NOMINAL, 3)
TOOL = make_transform(Rotation.from_euler("y", 30, degrees=True).as_matrix(), [0.05, 0.0, 0.2])
FRAME = make_transform(Rotation.from_euler("z", 15, degrees=True).as_matrix(), [0.6, -0.1, 0.05])
Q = np.deg2rad([[10, -80, 100, 5, 40, 15], [15, -85, 105, 0, 45, 10]])
# the tool and frame above in each language's --tool / --frame notation (mm or m, its angles)
ZYX = ("50,0,200,0,30,0", "600,-100,50,15,0,0")  # KRL A B C: about z, y, x
RPY = ("50,0,200,0,30,0", "600,-100,50,0,0,15")  # INFORM Rx Ry Rz, FANUC W P R, VAL3 rx ry rz
OWN = {"rapid": ("tReal", "50,0,200,0.96592583,0,0.25881905,0", "wCell",
                 "600,-100,50,0.99144486,0,0,0.13052619"),
       "krl": ("1", ZYX[0], "1", ZYX[1]), "inform": ("1", RPY[0], "1", RPY[1]),
       "fanuc": ("1", RPY[0], "1", RPY[1]),
       "val3": ("tReal", RPY[0], "fCell", RPY[1]),
       "urscript": ("tcp", "0.05,0,0.2,0,0.5235987756,0", "Cell", "0.6,-0.1,0.05,0,0,0.2617993878")}


def _program(key: str, folder: Path) -> tuple[list[Path], list[Path]]:
    """A program in language ``key`` moving with TOOL in FRAME, which it or its controller files
    (the references) declare: KRL $config.dat, INFORM TOOL.CND and UFRAME.CND, FANUC SYSFRAME.VA."""
    paths, _, _ = write_program(key, folder, NOMINAL, Q, TOOL, FRAME)
    refs = []
    if key == "krl":
        refs = [folder / "config.dat"]
        refs[0].write_text("DEFDAT $CONFIG\nTOOL_DATA[1]={X 50.0,Y 0.0,Z 200.0,A 0.0,B 30.0,C 0.0}\n"
                           "BASE_DATA[1]={X 600.0,Y -100.0,Z 50.0,A 15.0,B 0.0,C 0.0}\nENDDAT\n")
    elif key == "inform":
        refs = [folder / "TOOL.CND", folder / "UFRAME.CND"]
        refs[0].write_bytes(b"//TOOL 1\r\n///NAME T1\r\n50.000,0.000,200.000,0.0000,30.0000,0.0000\r\n"
                            b"0.000,0.000,0.000\r\n0.000\r\n0.000,0.000,0.000\r\n0.000,0,1\r\n")
        refs[1].write_bytes(b"//UFRAME 1\r\n///NAME CELL\r\n///TOOL 0\r\n"
                            b"////BUSER 600.000,-100.000,50.000,0.0000,0.0000,15.0000\r\n")
    elif key == "fanuc":
        refs = [folder / "SYSFRAME.VA"]
        block = ("    [1,1] = \n  Group: 1   Config: N D B, 0, 0, 0\n  X: {}   Y: {}   Z: {}\n"
                 "  W: {}   P: {}   R: {}\n")
        refs[0].write_text(
            "[*SYSTEM*]$MNUFRAME  Storage: SHADOW  Access: RW  : ARRAY[1,1] OF POSITION\n"
            + block.format("600.000", "-100.000", "50.000", "0.000", "0.000", "15.000")
            + "[*SYSTEM*]$MNUTOOL  Storage: SHADOW  Access: RW  : ARRAY[1,1] OF POSITION\n"
            + block.format("50.000", "0.000", "200.000", "0.000", "30.000", "0.000"))
    elif key == "urscript":  # the TCP as a named pose, which --tool tcp= replaces
        text = paths[0].read_text()
        start = text.index("set_tcp(") + len("set_tcp(")
        end = text.index(")", start)
        paths[0].write_text(text[:start - 8] + f"global tcp={text[start:end]}\n  set_tcp(tcp" + text[end:])
    return paths, refs


def _shifted(text: str, mm: float, key: str) -> str:
    """``text`` with its x moved by ``mm`` (in the language's unit)."""
    values = text.split(",")
    values[0] = f"{float(values[0]) + (mm * 1e-3 if key == 'urscript' else mm):.6g}"
    return ",".join(values)


@pytest.mark.parametrize("key", list(OWN))
def test_a_tool_or_frame_given_is_compared_with_the_programs_own_in_every_language(key, tmp_path):
    """The program's own tool and frame given again: no warning; a tool 0.42 mm and a frame 0.16 mm
    off (the cases of the issue: VAL3 warned only above 0.5 mm, INFORM frames never): named."""
    paths, refs = _program(key, tmp_path)
    tool, tool_text, frame, frame_text = OWN[key]
    same = filter_program(paths, CALIBRATED, NOMINAL, tools={tool: tool_text}, frames={frame: frame_text},
                          references=refs)
    assert not [w for w in same.warnings if "replaces the program's own" in w], same.warnings
    res = filter_program(paths, CALIBRATED, NOMINAL, tools={tool: _shifted(tool_text, 0.42, key)},
                         frames={frame: _shifted(frame_text, 0.16, key)}, references=refs)
    said = [w for w in res.warnings if "replaces the program's own" in w]
    assert len(said) == 2, res.warnings
    assert said[0].startswith(f"--tool {tool}=") and "differs from it by 0.42 mm," in said[0]
    assert said[1].startswith(f"--frame {frame}=") and "differs from it by 0.16 mm," in said[1]
    assert [r["correction_mm"] for r in res.rows] != [r["correction_mm"] for r in same.rows]  # they are used


def test_the_override_warning_through_the_command_line(tmp_path, capsys):
    paths, refs = _program("inform", tmp_path)
    cal = tmp_path / "cal.yaml"
    CALIBRATED.save(cal)
    args = ["filter", *map(str, paths), "--calibrated", str(cal), "--nominal", "kuka_kr16_2",
            "-o", str(tmp_path / "out"), "--tool", f"1={RPY[0]}",
            "--frame", f"1={_shifted(RPY[1], 0.16, 'inform')}",
            *[a for r in refs for a in ("--references", str(r))]]
    assert main(args) == 0
    out = capsys.readouterr()
    err = out.out + out.err
    assert "--frame 1=600.16,-100,50,0,0,15 replaces the program's own frame 1" in err
    assert "--tool 1=" not in err


def test_a_rotation_is_judged_by_how_far_it_moves_a_working_point():
    """0.005 deg on a frame moves a point at a 1.6 m reach 0.14 mm: said; on a tool of 200 mm,
    0.017 mm: not (the tolerance is what a point moves, CALIBRATED_TCP_MM)."""
    from robocal.programs.overrides import override_disagreements

    d = dialect_named("inform")
    own = d.frame_from_text("0,0,200,0,0,0")
    assert override_disagreements(d, "frame", {"1": own}, {"1": "0,0,200,0,0,0.005"}, 1.6)
    assert not override_disagreements(d, "tool", {"1": own}, {"1": "0,0,200,0,0,0.005"}, 1.6)
    assert 0.2 * np.deg2rad(0.005) * 1e3 < CALIBRATED_TCP_MM < 1.6 * np.deg2rad(0.005) * 1e3


def _payload_data(tmp_path: Path, robot: str, masses: list[float], scale: float) -> Path:
    """Simulated point data of catalog ``robot`` carrying ``masses`` (kg) in turn, the payload_kg
    column written as kg times ``scale`` (2.2046: pounds, 1000: grams)."""
    nominal = rc.Robot.from_catalog(robot)
    sim = rc.simulate_tracker(nominal, 24, payloads=masses, seed=4)
    path = tmp_path / f"{robot}.csv"
    sim.data.save(path)
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    k = lines[0].split(",").index("payload_kg")
    rows = [line.split(",") for line in lines[1:]]
    for r in rows:
        r[k] = f"{float(r[k]) * scale:.6g}"
    path.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    return path


@pytest.mark.parametrize(("robot", "masses", "scale", "unit"), [
    ("kuka_kr210_r2700", [0.0, 180.0], 1 / 0.45359237, "pounds"),  # 397 "kg" on a 210 kg robot
    ("fanuc_lrmate200id", [0.0, 4.0], 1000.0, "grams")])  # 4,000 "kg" on a 7 kg one
def test_a_payload_column_in_another_unit_is_refused_against_the_rated_payload(tmp_path, capsys, robot,
                                                                              masses, scale, unit):
    """The catalog's rated payload (Robot.payload_kg) is the yardstick: a payload_kg column in lb
    or g is refused naming the unit, by the API and the command line (exit 2); in kg it loads."""
    nominal = rc.Robot.from_catalog(robot)
    in_kg = _payload_data(tmp_path, robot, masses, 1.0)
    assert nominal.payload_kg is not None and rc.Measurements.load(in_kg, robot=nominal).payload is not None
    path = _payload_data(tmp_path, robot, masses, scale)
    with pytest.raises(rc.UnitError, match=f"times the rated payload of {robot} .*look like {unit}"):
        rc.Measurements.load(path, robot=nominal)
    data = rc.Measurements.load(path)  # read without the robot: calibrate checks it against the model
    with pytest.raises(rc.UnitError, match=f"look like {unit}"):
        rc.calibrate(nominal, data)
    assert main(["calibrate", str(path), "--robot", robot, "-o", str(tmp_path / "cal.yaml")]) == 2
    assert f"look like {unit}" in capsys.readouterr().err
    assert not (tmp_path / "cal.yaml").exists()


def test_a_payload_option_in_grams_is_refused_by_the_filter(tmp_path):
    paths, refs = _program("krl", tmp_path)
    with pytest.raises(rc.UnitError, match=r"--payload: 5000 kg .* rated payload of kuka_kr16_2 .*grams"):
        filter_program(paths, CALIBRATED, NOMINAL, payload=5000.0, references=refs)
    assert filter_program(paths, CALIBRATED, NOMINAL, payload=5.0, references=refs).rows
    cal = tmp_path / "cal.yaml"
    CALIBRATED.save(cal)
    args = ["filter", *map(str, paths), "--calibrated", str(cal), "--nominal", "kuka_kr16_2", "-o",
            str(tmp_path / "out"), "--payload", "5000", *[a for r in refs for a in ("--references", str(r))]]
    assert main(args) == 2 and not (tmp_path / "out").exists()
    with pytest.raises(rc.UnitError, match="--payload: 35.27 kg .*pounds"):  # 16 kg in lb to compensate
        rc.compensate(CALIBRATED, NOMINAL, NOMINAL.fk(Q), payload=16 / 0.45359237)
    paths, refs = _program("fanuc", tmp_path)  # schedules of a controller in lb
    with pytest.raises(rc.UnitError, match=r"--payload-schedules: 33.07 kg .*pounds"):
        filter_program(paths, CALIBRATED, NOMINAL, payload_schedules={1: (15.0 / 0.45359237, 0, 0, 0)},
                       references=refs)


TRACK_CELL = """units: {{length: mm, angle: deg}}
robot: kuka_kr210_r2700
track: {{direction: [1, 0, 0], limits: [0, 6000]}}
mount: {{xyz: [0, 0, {riser}]}}
"""
WORK_CELL = """units: {{length: mm, angle: deg}}
robots:
  left: {{model: abb_irb2600, unit: ROB_1, base: {{xyz: [0, 0, {riser}]}}}}
positioner:
  unit: STN1
  mount: {{xyz: [{mount}, 0, 0]}}
  axes: [{{type: revolute, axis: [1, 0, 0], origin: [0, 0, {height}], limits: [-90, 90]}}]
"""


@pytest.mark.parametrize(("text", "good", "bad", "key"), [
    (TRACK_CELL, {"riser": 500}, {"riser": 0.5}, "mount"),  # a 500 mm riser written 0.5 in a file in mm
    (WORK_CELL, {"riser": 500, "mount": 1400, "height": 900}, {"riser": 0.5, "mount": 1400, "height": 900},
     "robots.left.base"),
    (WORK_CELL, {"riser": 0, "mount": 1400, "height": 900}, {"riser": 0, "mount": 1.4, "height": 900},
     "positioner.mount"),
    (WORK_CELL, {"riser": 0, "mount": 1400, "height": 900}, {"riser": 0, "mount": 1400, "height": 0.9},
     "positioner.axes' origins"),
    (WORK_CELL.replace("mm", "m", 1), {"riser": 0.5, "mount": 1.4, "height": 0.9},
     {"riser": 500, "mount": 1.4, "height": 0.9}, "robots.left.base")])  # 500 'm' on a 3 m arm
def test_a_cell_offset_in_another_unit_is_refused_against_the_arms_size(tmp_path, capsys, text, good, bad,
                                                                        key):
    """A riser, a base, a positioner's mount or axis height whose number, read in the file's unit,
    is no offset this arm's cell has (links add up to ~3 m) is refused naming the unit it fits, by
    the API and the command line (exit 2); the same offset written in the file's unit loads."""
    path = tmp_path / "cell.yaml"
    path.write_text(text.format(**good))
    assert rc.load_cell(path).bodies
    path.write_text(text.format(**bad))
    with pytest.raises(rc.RobocalError, match=rf"cell.yaml: {re.escape(key)}: .* the values look like"):
        rc.load_cell(path)
    args = ["simulate", "--model", str(path), "--poses", "10", "-o", str(tmp_path / "d.csv"), "--truth",
            str(tmp_path / "t.yaml")]
    assert main(args) == 2
    assert f"{key}: " in capsys.readouterr().err and not (tmp_path / "d.csv").exists()


def test_a_frame_rotation_is_judged_at_its_farthest_target(tmp_path):
    """The lever of a frame is the distance of its farthest target (frame_levers), not the reach:
    0.002 deg on a frame whose targets lie within 0.9 m moves them 0.03 mm (not said), 0.01 deg
    0.15 mm (said, naming that distance)."""
    from robocal.programs.overrides import frame_levers

    paths, refs = _program("krl", tmp_path)
    res = filter_program(paths, CALIBRATED, NOMINAL, frames={"1": "600,-100,50,15.002,0,0"}, references=refs)
    assert not [w for w in res.warnings if "replaces the program's own" in w]
    res = filter_program(paths, CALIBRATED, NOMINAL, frames={"1": "600,-100,50,15.01,0,0"}, references=refs)
    said = [w for w in res.warnings if "replaces the program's own" in w]
    krl = dialect_named("krl")
    program = krl.parse([ProgramText(p) for p in paths], {}, {}, [ProgramText(r) for r in refs])
    far = frame_levers(krl, program)["1"]
    assert 0.8 < far < 0.9 and len(said) == 1 and f"a point {far * 1e3:.4g} mm away" in said[0]


def test_an_offset_no_unit_explains_and_a_rated_payload_on_a_track_pass(tmp_path):
    """A 1 mm shim under an arm in a cell file in metres fits no other unit: it loads (only an
    offset another unit explains is refused); an arm on a track keeps its rated payload."""
    path = tmp_path / "cell.yaml"
    path.write_text(TRACK_CELL.format(riser=0.001).replace("mm", "m", 1).replace("6000", "6"))
    chain = rc.load_model(str(path))
    assert chain.base is not None and chain.payload_kg == rc.Robot.from_catalog("kuka_kr210_r2700").payload_kg


def test_an_unnamed_urscript_tool_the_script_never_uses_is_said(tmp_path):
    """The installation's TCP (--tool without a name) serves no motion of a script that sets its
    own TCP before every motion: said, not silently dropped."""
    paths, _, _ = write_program("urscript", tmp_path, NOMINAL, Q, TOOL, FRAME)
    res = filter_program(paths, CALIBRATED, NOMINAL, tools={"": "0.05,0,0.25,0,0.5235987756,0"})
    assert any(w.startswith("--tool (the installation's TCP) is not used") and "set_tcp@2" in w
               for w in res.warnings), res.warnings
