"""The reproducers of the fuzzing campaign of issue 25, each a clean one-line refusal or a named
warning: schema violations of the result JSON, absurd URDF and model values, joint readings past
the limits, program typos that used to drop a target silently, quiet runs that hid warnings,
floating-point warnings, an all-stray drift monitor, Ctrl-C at start-up."""

from __future__ import annotations

import json
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import children
import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError, ModelError
from robocal.data.simulate import perturbed
from robocal.kinematics.urdf import from_urdf, to_urdf
from robocal.programs import filter_program

PROGRAMS = Path(__file__).parent / "data" / "programs"
DEMO = Path(rc.__file__).parent / "demo_data"


def _one_line_error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith(f"robocal {argv[argv[0] == '--quiet']}: error: "), err
    return err


# ----------------------------------------------------------------- result JSON (robocal report)
@pytest.fixture(scope="module")
def result_json(tmp_path_factory) -> dict:
    d = tmp_path_factory.mktemp("result")
    assert main(["--quiet", "simulate", "--robot", "abb_irb2600", "--poses", "40", "--seed", "3", "-o",
                 str(d / "cal.csv"), "--truth", str(d / "truth.yaml")]) == 0
    assert main(["--quiet", "calibrate", str(d / "cal.csv"), "--robot", "abb_irb2600", "--nongeometric",
                 "none", "--json", str(d / "r.json")]) == 0
    return json.loads((d / "r.json").read_text())


def _broken(data: dict, path: str, value) -> dict:
    data = json.loads(json.dumps(data))
    *parents, last = path.split(".")
    node = data
    for key in parents:
        node = node[int(key)] if isinstance(node, list) else node[key]
    node[int(last) if isinstance(node, list) else last] = value
    return data


@pytest.mark.parametrize("path, value, field", [
    ("provenance", 7, "provenance: expected a mapping"),
    ("history", "abc", "history: expected a list"),
    ("settings", [1, 2], "settings: expected a mapping"),
    ("observations.joints_deg.3", [1.0, 2.0], r"observations.joints_deg\[3\]: expected 6 numbers, got 2"),
    ("observations.error_after", [0.1, 0.2], "observations: arrays of different lengths"),
    ("before.rms", "0.5", "before.rms: expected a number"),
    ("parameters.0.estimate", 1e300, r"parameters\[0\].estimate: .* beyond"),
    ("correlation.matrix", [[1.0]], "correlation.matrix: expected"),
    ("robot.n_joints", True, "robot.n_joints: expected an integer"),
    ("warnings", [None], r"warnings\[0\]: is null"),
])
def test_result_json_fields_are_validated(result_json, tmp_path, capsys, path, value, field):
    src = tmp_path / "r.json"
    src.write_text(json.dumps(_broken(result_json, path, value)))
    err = _one_line_error(capsys, ["report", str(src), "-o", str(tmp_path / "r.html")])
    assert str(src) in err
    assert __import__("re").search(field, err), err
    assert not (tmp_path / "r.html").exists()


def test_result_json_huge_integer_deep_nesting_and_nan(result_json, tmp_path, capsys):
    src = tmp_path / "r.json"
    text = json.dumps(result_json)
    for bad, match in ((text.replace('"rank": ', '"rank": ' + "1" * 5000 + ", \"x\": ", 1), "digits"),
                       (text[:-1] + ', "deep": ' + "[" * 100_000 + "]" * 100_000 + "}", "nested too deeply"),
                       (text.replace('"rms": ', '"rms": NaN, "y": ', 1), "NaN is not a JSON number")):
        src.write_text(bad)
        assert match in _one_line_error(capsys, ["report", str(src), "-o", str(tmp_path / "r.html")])


@pytest.mark.parametrize("absent", [("model_after",), ("model_after", "measured", "error_before")])
def test_a_result_without_optional_rows_still_renders(result_json, tmp_path, absent):
    data = json.loads(json.dumps(result_json))
    for key in absent:
        data["observations"][key] = None
    data["observations"]["pose_id"] = [0] * len(data["observations"]["pose_id"])  # all repeats of one pose
    src = tmp_path / "r.json"
    src.write_text(json.dumps(data))
    assert main(["--quiet", "report", str(src), "-o", str(tmp_path / "r.html")]) == 0


def test_mathtext_in_result_strings_is_shown_as_text(result_json, tmp_path, capsys):
    data = _broken(result_json, "history_units.rms", "$\\frac{a$")
    data["correlation"]["names"][0] = "$x^$"
    src = tmp_path / "r.json"
    src.write_text(json.dumps(data))
    assert main(["--quiet", "report", str(src), "-o", str(tmp_path / "r.html")]) == 0
    assert "$x^$" in (tmp_path / "r.html").read_text()


# ----------------------------------------------------------------- models and URDF
@pytest.mark.parametrize("old, new, match", [
    ('origin xyz="0.15 0.0 0.0"', 'origin xyz="0.15 0.0 2e9"', "beyond"),
    ('origin xyz="0.15 0.0 0.0"', 'origin xyz="1e308 0.0 0.0"', "beyond"),
    ('lower="-1.6580627893946132"', 'lower="abc"', "is not a list of numbers"),
    ('<axis xyz="0 0 1"/>', '<axis xyz="0 0 1e308"/>', "beyond"),
    ('<link name="link_2"/>', "<link/>", "without a name"),
])
def test_urdf_values_are_numbers_of_a_robot(old, new, match):
    text = to_urdf(rc.Robot.from_catalog("abb_irb2600"))
    assert old in text, old
    with pytest.raises(ModelError, match=match) as err:
        from_urdf(text.replace(old, new, 1))
    assert "\n" not in str(err.value)


def test_model_files_refuse_absurd_values_and_malformed_units(tmp_path, capsys):
    text = (Path(rc.__file__).parent / "catalog" / "puma560.yaml").read_text()
    m = tmp_path / "m.yaml"
    for bad, match in ((text.replace("units: {length: m,", "units: {length: [m],", 1), "unknown units"),
                       ("units: {length: m, angle: rad}\nmdh: {alpha: [0], a: [2e9], theta: [0], d: [0]}\n",
                        "m.yaml: a[0] = 2e+09 m is beyond"),
                       ("a: " + "[" * 1000 + "]" * 1000, "nested deeper"),
                       ("units: {length: m, angle: rad}\nnominal: [[1, 2], [3]]\n"
                        "mdh: {alpha: [0], a: [0], theta: [0], d: [0]}\n", "nominal")):
        m.write_text(bad)
        assert match in _one_line_error(capsys, ["export", str(m), "--urdf", str(tmp_path / "o.urdf")])
    laughs = "units: {length: m, angle: rad}\nmdh: {alpha: [0], a: [0], theta: [0], d: [0]}\n" + \
        "x0: &a0 [1, 1]\n" + "".join(f"x{i}: &a{i} [*a{i - 1}, *a{i - 1}]\n" for i in range(1, 21)) + \
        "description: *a20\n"
    assert len(laughs) < 700
    m.write_text(laughs)
    err = _one_line_error(capsys, ["export", str(m), "--urdf", str(tmp_path / "o.urdf")])
    assert "once its aliases are expanded" in err and len(err) < 300


# ----------------------------------------------------------------- joint readings and limits
def _demo_with(tmp_path, row: int, column: str, value: float) -> Path:
    lines = (DEMO / "calibration.csv").read_text().splitlines()
    header = lines[1].split(",")
    cells = lines[2 + row].split(",")
    cells[header.index(column)] = repr(float(value))
    lines[2 + row] = ",".join(cells)
    out = tmp_path / "data.csv"
    out.write_text("\n".join(lines) + "\n")
    return out


def test_joint_readings_past_the_limits_are_named_or_refused(tmp_path, capsys):
    robot = rc.Robot.from_catalog("abb_irb2600")
    near = _demo_with(tmp_path, 7, "q5_rad", robot.limits[4, 1] + np.deg2rad(5))
    assert main(["--quiet", "evaluate", "abb_irb2600", str(near), "--fit-frame", "--force"]) == 0
    out = capsys.readouterr().out
    assert "joint readings outside abb_irb2600's joint limits" in out and "row 9 q5 = 125 deg" in out
    far = _demo_with(tmp_path, 5, "q3_rad", 12.0)  # 687.5 deg on a joint limited to -180..75 deg
    err = _one_line_error(capsys, ["--quiet", "evaluate", "abb_irb2600", str(far), "--fit-frame"])
    assert "more than 90 deg outside" in err and "row 7 q3 = 687.549 deg" in err
    err = _one_line_error(capsys, ["--quiet", "calibrate", str(far), "--robot", "abb_irb2600",
                                   "--nongeometric", "none", "-o", str(tmp_path / "c.yaml")])
    assert "row 7 q3" in err and not (tmp_path / "c.yaml").exists()


# ----------------------------------------------------------------- programs: typos are refused
@pytest.mark.parametrize("old, new, line", [
    ("P[3]{", "P[3!]{", 49), ("P[3]{\n   GP1:", "P[3]{\n   gp1:", 49),
    ("P[3]{\n   GP1:", "P[3]{\n   GP1_000:", 49), ("R =   -21.423 deg\n};", "R =   -21.423 deg\n", 49),
    ("'F U T, 0, 0, 0'", "'F U T, 0, 0, " + "1" * 5000 + "'", 51),  # the digits' own line
    ("UF : 1, UT : 2,\t\tCONFIG : 'F", "UF : " + "1" * 5000 + ", UT : 2,\t\tCONFIG : 'F", 51),
], ids=["P[3!]", "gp1", "GP1_000", "no };", "5000-digit turn", "5000-digit UF"])
def test_fanuc_position_block_typos_are_refused(tmp_path, old, new, line):
    text = (PROGRAMS / "sealing.ls").read_text()
    assert old in text
    bad = tmp_path / "sealing.ls"
    bad.write_text(text.replace(old, new, 1))
    robot = rc.Robot.from_catalog("fanuc_lrmate200id")
    with pytest.raises(DataError, match=f"sealing.ls:{line}: ") as err:
        filter_program(bad, perturbed(robot, 7), robot, frames={"1": "450,-150,100,0,0,-10"},
                       tools={"2": "0,0,120,0,0,0"})
    assert "\n" not in str(err.value)


def test_urscript_pose_trans_without_comma_is_named(tmp_path):
    text = (PROGRAMS / "pick_place.script").read_text()
    bad = tmp_path / "p.script"
    bad.write_text(text.replace("pose_trans(Tray, p[-0.465729", "pose_trans(Tray p[-0.465729", 1))
    robot = rc.Robot.from_catalog("ur5")
    res = filter_program(bad, perturbed(robot, 7), robot)  # the motion is named, not skipped silently
    assert any(re.match(r"p.script:17: movec: not corrected: pose_trans takes two arguments", u)
               for u in res.uncorrected)


def test_urscript_qnear_must_be_six_numbers(tmp_path):
    text = (PROGRAMS / "pick_place.script").read_text()
    bad = tmp_path / "p.script"
    bad.write_text(text.replace("global Waypoint_1_q=[0.0,", "global Waypoint_1_q=[[0.0],", 1).replace(
        "qnear=Waypoint_1_q", "qnear=[[0.0], -1.5708, 1.5708, -1.5708, -1.5708, 0.0]", 1))
    robot = rc.Robot.from_catalog("ur5")
    with pytest.raises(DataError, match=r"p.script:11: qnear must be a list of 6 joint values"):
        filter_program(bad, perturbed(robot, 7), robot)


def test_rapid_target_declared_nowhere_is_named_and_parameters_pass(tmp_path):
    text = (PROGRAMS / "weld_cell.mod").read_text()
    robot = rc.Robot.from_catalog("abb_irb2600")
    bad = tmp_path / "w.mod"
    bad.write_text(text.replace("MoveL pSeamStart,", "MoveL pSeamStrat,", 1))
    res = filter_program(bad, perturbed(robot, 7), robot)  # the motion is named, not skipped silently
    assert any(re.match(r"w.mod:34: MoveL: not corrected: robtarget pSeamStrat is not declared", u)
               for u in res.uncorrected)
    # a robtarget parameter of a routine, or a variable set at run time, is not a typo
    via = ("    PROC Via(robtarget pVia)\n        MoveL pVia, v100, z1, tGun;\n"
           "        MoveL pScratch, v100, z1, tGun;\n    ENDPROC\n\n    PROC Leave()")
    good = text.replace("    PROC Leave()", via, 1)
    bad.write_text(good)
    assert filter_program(bad, perturbed(robot, 7), robot).rows


# ----------------------------------------------------------------- quiet, warnings, interrupts
def test_quiet_import_still_lists_dropped_readings(tmp_path, capsys):
    rows = np.hstack([np.random.default_rng(0).uniform(-90, 90, (6, 6)),
                      np.random.default_rng(1).uniform(-1, 1, (6, 3))])
    rows[2, 6:] = 0.0  # a failed reading
    raw = tmp_path / "raw.csv"
    raw.write_text("\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    assert main(["--quiet", "import", str(raw), "--joints", "cols=0-5:deg", "--points", "cols=6-8:m",
                 "-o", str(tmp_path / "out.csv")]) == 0
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith("robocal import: warning: dropped 1 failed reading(s)")
    assert "line 3" in captured.err


def test_a_drift_monitor_with_every_reading_stray_is_one_line(tmp_path, capsys):
    rows = np.hstack([np.random.default_rng(0).uniform(-90, 90, (4, 6)),
                      np.random.default_rng(1).uniform(-1, 1, (4, 3))])
    raw = tmp_path / "raw.csv"
    raw.write_text("\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    base = tmp_path / "base.txt"
    base.write_text("100 0 0\n110 0 0\n100 10 0\n110 10 0\n")
    err = _one_line_error(capsys, ["import", str(raw), "--joints", "cols=0-5:deg", "--points", "cols=6-8:m",
                                   "--base", f"{base}:mm", "-o", str(tmp_path / "out.csv")])
    assert "every base reading is more than 1 mm from their median" in err


def test_floating_point_overflow_is_a_one_line_error(tmp_path, capsys):
    assert main(["--quiet", "simulate", "--robot", "abb_irb2600", "--poses", "12", "--kind", "pose",
                 "--seed", "1", "-o", str(tmp_path / "p.csv"), "--truth", str(tmp_path / "t.yaml")]) == 0
    lines = (tmp_path / "p.csv").read_text().splitlines()
    header = next(i for i, ln in enumerate(lines) if ln.startswith("pose_id") or "qw" in ln)
    cells = lines[header + 3].split(",")
    cells[lines[header].split(",").index("qw")] = "1e308"
    lines[header + 3] = ",".join(cells)
    (tmp_path / "p.csv").write_text("\n".join(lines) + "\n")
    err = _one_line_error(capsys, ["evaluate", str(tmp_path / "t.yaml"), str(tmp_path / "p.csv")])
    assert "RuntimeWarning" not in err


def test_ctrl_c_while_the_command_line_starts_is_one_line_and_130(monkeypatch, capsys):
    import robocal.cli as cli

    def interrupted(name):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli.importlib, "import_module", interrupted)
    assert main(["robots"]) == 130
    assert capsys.readouterr().err == "robocal: interrupted\n"


@pytest.mark.slow
def test_ctrl_c_at_any_moment_of_a_real_run(tmp_path):
    """SIGINT at increasing delays into `robocal calibrate` (start-up imports, reading, solving,
    writing): one line and exit 130, or the run had finished. Python's own start-up (site
    import, before robocal's code runs) is outside robocal and not judged."""
    data = tmp_path / "cal.csv"
    shutil.copy(DEMO / "calibration.csv", data)
    # SIGINT back to Python's default: a child of a background pytest inherits it ignored (and the
    # command line rightly leaves an ignored SIGINT ignored: nothing would be tested)
    code = ("import signal, sys\n"
            "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
            "from robocal.cli import main\n"
            "sys.exit(main())")
    exe = [sys.executable, "-c", code]
    for delay in (0.2, 0.4, 0.7, 1.0, 1.5):
        child = subprocess.Popen([*exe, "calibrate", str(data), "--robot", "abb_irb2600", "--nongeometric",
                                  "none", "-o", str(tmp_path / "c.yaml")], stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE, text=True)
        time.sleep(delay)
        child.send_signal(signal.SIGINT)
        err = children.communicate(child, f"end {delay} s after SIGINT", 120)[1]
        if "init_import_site" in err or child.returncode == -signal.SIGINT:
            continue  # the interpreter was still starting
        assert child.returncode in (0, 130), err
        if child.returncode == 130:
            assert err.strip().count("\n") == 0 and err.strip().endswith("interrupted"), err


@pytest.mark.parametrize("old, new", [
    ("        [[580.79,302.20,20.66],", "        [580.79,302.20,20.66],"),  # an element's brackets lost
    ("[[404.95,558.12,", "[[[],558.12,"),  # an empty aggregate where a number stands
], ids=["lost brackets", "empty aggregate"])
def test_rapid_malformed_array_element_is_refused(tmp_path, old, new):
    """Found by the long fuzz on the data-flow parser: a robtarget array element that is not an
    aggregate of aggregates was an internal error."""
    text = (PROGRAMS / "weld_cell.mod").read_text()
    assert old in text
    bad = tmp_path / "w.mod"
    bad.write_text(text.replace(old, new, 1))
    robot = rc.Robot.from_catalog("abb_irb2600")
    with pytest.raises(DataError, match=r"w.mod:\d+: malformed robtarget pSeam\{\d\}"):
        filter_program(bad, perturbed(robot, 7), robot)


def test_fanuc_position_numbers_of_thousands_of_digits(tmp_path):
    """Found by the long fuzz: a 5,000-digit position number was an internal error (Python's
    int conversion limit); such a run of digits is no program a controller wrote: refused on
    reading, naming its line, in /POS and in a motion alike."""
    text = (PROGRAMS / "sealing.ls").read_text()
    robot = rc.Robot.from_catalog("fanuc_lrmate200id")
    kw = {"frames": {"1": "450,-150,100,0,0,-10"}, "tools": {"2": "0,0,120,0,0,0"}}
    bad = tmp_path / "sealing.ls"
    bad.write_text(text.replace("P[3]{", "P[" + "1" * 5000 + "]{", 1))
    with pytest.raises(DataError, match=r"sealing.ls:49: a number of 5000 digits"):
        filter_program(bad, perturbed(robot, 7), robot, **kw)
    motion = text.index("P[3]", text.index("/MN"))
    bad.write_text(text[:motion] + "P[" + "1" * 5000 + "]" + text[motion + 4:])
    with pytest.raises(DataError, match=r"sealing.ls:\d+: a number of 5000 digits"):
        filter_program(bad, perturbed(robot, 7), robot, **kw)
