"""A new user's mistakes on arms read from URDF, MDH and OPW files (Kawasaki RS007N and BX200L,
Denso VS-060, Comau NJ220, Nachi MZ25, a Franka Panda, a 5-axis arm, an Epson G6 SCARA), typed
through the command line: each is refused in one line naming the cause, warned naming the problem
or handled right, and the same arms measured cleanly raise no warning. Truth: simulated campaigns
(`robocal simulate`, its truth YAML measured again with ``--as-is`` after the mistake is made)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.cli import main
from robocal.core.magnitudes import ARM_TEMPERATURE_C, fahrenheit_to_celsius, temperature_note

# Comau N 220-2.7 and Nachi MZ25 (robotkinematicscatalogue MDH rows: alpha rad, a mm, d mm, theta rad),
# the same tables as tests/test_opw_geometry.py, written as a user's model files
_COMAU_N220 = [[0, 0, 775, 0], [-np.pi / 2, 400, 0, -np.pi / 2], [0, 1050, 0, -np.pi / 2],
               [-np.pi / 2, 280, 1220, 0], [np.pi / 2, 0, 0, 0], [-np.pi / 2, 0, 229.5, np.pi]]
_NACHI_MZ25 = [[0, 0, 550, 0], [-np.pi / 2, 170, 0, 0], [0, 880, 0, 0], [-np.pi / 2, 190, 810, 0],
               [np.pi / 2, 0, 0, 0], [-np.pi / 2, 0, 115, 0]]
_LIMITS = [[-170, 170], [-90, 150], [-170, 80], [-200, 200], [-125, 125], [-360, 360]]
# Kawasaki BX200L as an OPW parameter file (m; approximate public dimensions), rated 200 kg
BX200L_YAML = """\
name: kawasaki_bx200l
payload_kg: 200
opw: {a1: 0.29, a2: -0.23, b: 0.0, c1: 0.695, c2: 1.1, c3: 1.35, c4: 0.23,
      offsets: [0, 0, -90, 0, 0, 0], signs: [1, 1, 1, 1, 1, 1]}
units: {length: m, angle: deg}
limits: [[-160, 160], [-60, 76], [-75, 90], [-210, 210], [-125, 125], [-210, 210]]
"""


def _mdh_file(path: Path, name: str, rows, payload: float) -> str:
    r = np.array(rows, float)
    deg = [[round(float(v), 6) for v in np.rad2deg(c)] for c in (r[:, 0], r[:, 3])]
    path.write_text(f"name: {name}\nunits: {{length: mm, angle: deg}}\npayload_kg: {payload}\nmdh:\n"
                    f"  alpha: {deg[0]}\n  a: {r[:, 1].tolist()}\n  theta: {deg[1]}\n"
                    f"  d: {r[:, 2].tolist()}\nlimits: {_LIMITS}\n")
    return str(path)


def _run(argv: list[str], capsys) -> tuple[int, str]:
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out + out.err


def _simulate(robot: str, out: Path, *extra) -> Path:
    """Simulate a campaign of ``robot``; its truth is ``out`` with ``_truth.yaml``."""
    truth = out.with_name(out.stem + "_truth.yaml")
    assert main(["--quiet", "simulate", "--robot", robot, "-o", str(out), "--truth", str(truth),
                 *map(str, extra)]) == 0
    return truth


def _moved(truth: Path, out: Path, n: int, seed: int, *, base_mm=None, tool_mm=None, joint=None) -> Path:
    """Measure ``truth`` again (``--as-is``) after the tracker (base), the SMR (tool) or a link moved."""
    m = yaml.safe_load(truth.read_text())
    if base_mm is not None:
        m["base"]["xyz"] = (np.array(m["base"]["xyz"]) + np.array(base_mm) * 1e-3).tolist()
    if tool_mm is not None:
        m["tool"]["xyz"] = (np.array(m["tool"]["xyz"]) + np.array(tool_mm) * 1e-3).tolist()
    if joint is not None:
        m["joints"][joint[0]][joint[1]] += joint[2]
    moved = out.with_name(out.stem + "_moved.yaml")
    moved.write_text(yaml.safe_dump(m, sort_keys=False))
    _simulate(str(moved), out, "--as-is", "--poses", n, "--seed", seed)
    return out


def _scaled(src: Path, dst: Path, column: str, f) -> Path:
    """``src`` with the values of the columns matching ``column`` mapped by ``f``."""
    lines = src.read_text().splitlines()
    at = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    head = lines[at].split(",")
    cols = [i for i, h in enumerate(head) if re.fullmatch(column, h)]
    rows = []
    for line in lines[at + 1:]:
        v = line.split(",")
        for i in cols:
            v[i] = repr(float(f(float(v[i]))))
        rows.append(",".join(v))
    dst.write_text("\n".join(lines[:at + 1] + rows) + "\n")
    return dst


@pytest.fixture(scope="module")
def nachi(tmp_path_factory) -> dict:
    """The Nachi MZ25 from its MDH file: a 60-pose campaign, its calibration in a history."""
    d = tmp_path_factory.mktemp("nachi")
    model = _mdh_file(d / "mz25.yaml", "nachi_mz25", _NACHI_MZ25, 25)
    cal = d / "cal.csv"
    truth = _simulate(model, cal, "--poses", 60, "--seed", 1)
    history = d / "robots.sqlite"
    assert main(["--quiet", "calibrate", "--robot", model, str(cal), "-o", str(d / "calibrated.yaml"),
                 "--history", str(history), "--robot-id", "MZ-1"]) == 0
    return {"dir": d, "model": model, "cal": cal, "truth": truth, "history": history,
            "calibrated": d / "calibrated.yaml"}


def test_a_check_with_the_smr_moved_says_so_in_the_timeline(nachi, capsys):
    """The check names the re-seated SMR (not the robot); the history's text timeline and its HTML
    page carried an empty 'moved' column: now they name the SMR, 'not the robot'."""
    check = _moved(nachi["truth"], nachi["dir"] / "check.csv", 20, 61, tool_mm=[2, 2, 0])
    code, said = _run(["check", nachi["calibrated"], check, "--history", nachi["history"],
                       "--robot-id", "MZ-1"], capsys)
    assert code == 0 and "changed" in said and "the SMR on the tool" in said
    html, js = nachi["dir"] / "history.html", nachi["dir"] / "history.json"
    code, said = _run(["history", nachi["history"], "--robot-id", "MZ-1", "--report", html, "--json", js],
                      capsys)
    line = [ln for ln in said.splitlines() if " check " in ln][-1]
    assert code == 0 and "moved: SMR 2.8" in line and "(not the robot)" in line, said
    assert "SMR 2.8" in html.read_text() and '"frame_change"' in js.read_text()


def test_an_offsets_only_refit_after_a_bent_link_is_warned_without_a_history(nachi, capsys):
    """A crash bent the forearm (a3 +0.9 mm): the joint zeros alone leave ~0.5 mm per coordinate.
    With a history the full calibration's floor judges it; without one, the tracker's noise does
    (it was silent). A campaign where only the zeros moved raises no warning."""
    crash = _moved(nachi["truth"], nachi["dir"] / "crash.csv", 25, 41, joint=(2, "a", 0.0009))
    argv = ["calibrate", "--robot", nachi["model"], "--start", nachi["calibrated"], "--offsets-only"]
    code, said = _run([*argv, crash, "-o", nachi["dir"] / "offsets.yaml"], capsys)
    assert code == 0 and "the offsets-only re-fit leaves" in said and "instrument's noise" in said, said
    assert "recalibrate fully" in said
    clean = _moved(nachi["truth"], nachi["dir"] / "same.csv", 25, 44)
    code, said = _run([*argv, clean, "-o", nachi["dir"] / "offsets2.yaml"], capsys)
    assert code == 0 and "re-fit leaves" not in said and "WARNING" not in said, said


def test_files_of_two_tracker_setups_calibrated_together_are_named(nachi, capsys):
    """A second day's file measured with the tracker set up 5 mm off, calibrated with the first in
    one tracker frame: 2.35 mm RMS with no word of why; now the files' shift is named. Two files of
    one setup: no warning."""
    day2 = _moved(nachi["truth"], nachi["dir"] / "day2.csv", 40, 81, base_mm=[5, 0, 0])
    code, said = _run(["calibrate", "--robot", nachi["model"], nachi["cal"], day2,
                       "-o", nachi["dir"] / "two_days.yaml"], capsys)
    assert code == 0 and "the calibration files are shifted from each other" in said, said
    same = _moved(nachi["truth"], nachi["dir"] / "day1b.csv", 40, 91)
    code, said = _run(["calibrate", "--robot", nachi["model"], nachi["cal"], same,
                       "-o", nachi["dir"] / "one_day.yaml"], capsys)
    assert code == 0 and "shifted" not in said and "WARNING" not in said, said


def test_evaluate_with_the_frame_of_another_day_names_the_moved_tracker(nachi, capsys):
    """`evaluate --frame-from cal.csv` on a file measured after the tracker was re-registered 0.5 mm
    off: 0.498 mm RMS with no word (the model is 0.03 mm off); now the frame shift is named."""
    day2 = _moved(nachi["truth"], nachi["dir"] / "next_day.csv", 30, 11, base_mm=[0.5, 0, 0])
    code, said = _run(["evaluate", nachi["calibrated"], day2, "--frame-from", nachi["cal"]], capsys)
    assert code == 0 and "the tracker or the SMR moved between cal.csv and these data" in said, said
    same = _moved(nachi["truth"], nachi["dir"] / "same_day.csv", 30, 12)
    code, said = _run(["evaluate", nachi["calibrated"], same, "--frame-from", nachi["cal"]], capsys)
    assert code == 0 and "WARNING" not in said, said


def test_arm_temperatures_in_fahrenheit_are_named(tmp_path, capsys):
    """A BX200L campaign warming 20-35 deg C written in Fahrenheit (68-95): the thermal term fitted
    k 1.8 x too small, silently; now the column is named, the Celsius values given."""
    (tmp_path / "bx.yaml").write_text(BX200L_YAML)
    data = tmp_path / "warm.csv"
    _simulate(str(tmp_path / "bx.yaml"), data, "--poses", 40, "--seed", 1, "--temperatures", "20:35")
    f = _scaled(data, tmp_path / "warm_f.csv", "temperature_c", lambda c: c * 1.8 + 32)
    code, said = _run(["calibrate", "--robot", tmp_path / "bx.yaml", f, "--nongeometric", "thermal",
                       "-o", tmp_path / "c.yaml"], capsys)
    assert code == 0 and "read as degrees Fahrenheit they are 20 to 35 deg C" in said, said
    code, said = _run(["calibrate", "--robot", tmp_path / "bx.yaml", data, "--nongeometric", "thermal",
                       "-o", tmp_path / "c2.yaml"], capsys)
    assert code == 0 and "Fahrenheit" not in said


def test_the_temperature_note_against_an_independent_conversion():
    lo, hi = ARM_TEMPERATURE_C
    assert fahrenheit_to_celsius(212.0) == pytest.approx(100.0) and fahrenheit_to_celsius(-40.0) == -40.0
    assert temperature_note([lo, hi], "x") is None
    assert "check the column is in degrees Celsius" in temperature_note([100.0, 200.0], "x")
    assert "Fahrenheit" in temperature_note([hi + 1.0], "x")  # 61 F = 16 C: an arm's temperature


def test_a_quill_in_millimetres_under_a_metres_header_is_named(tmp_path, capsys):
    """The G6's quill (q3, prismatic) written in mm under q3_m: named as millimetres (it was
    'another robot's data, radians under _deg headers?')."""
    data = tmp_path / "g6.csv"
    _simulate("epson_g6_651s", data, "--poses", 30, "--seed", 1)
    mm = _scaled(data, tmp_path / "g6_mm.csv", "q3_m", lambda v: v * 1e3)
    code, said = _run(["calibrate", "--robot", "epson_g6_651s", mm, "-o", tmp_path / "c.yaml"], capsys)
    assert code == 2 and "the column holds millimetres under a metres header; name it q3_mm" in said, said
    assert not (tmp_path / "c.yaml").exists()


def test_payload_masses_in_grams_are_named(tmp_path, capsys):
    """Payloads of 0-6 kg written in grams on a 7 kg arm (6000 'kg', beyond any arm's)."""
    (tmp_path / "rs.yaml").write_text(BX200L_YAML.replace("200", "7", 1))
    data = tmp_path / "loads.csv"
    _simulate(str(tmp_path / "rs.yaml"), data, "--poses", 30, "--seed", 1, "--payloads", "0,3,6")
    g = _scaled(data, tmp_path / "loads_g.csv", "payload_kg", lambda v: v * 1e3)
    code, said = _run(["calibrate", "--robot", tmp_path / "rs.yaml", g, "-o", tmp_path / "c.yaml"], capsys)
    assert code == 2 and "grams: 6000 g = 6 kg" in said, said


def test_a_redundant_arm_is_compensated_from_the_joints_it_starts_at(tmp_path, capsys):
    """The Panda (7 joints, no closed form): compensate said 'use rc.ik.solve' (Python) to a
    command-line user; now it asks for --start and solves each target numerically from the previous
    one's joints. Truth: the targets are the nominal model's poses, the corrected joints put the
    calibrated model's flange on them."""
    model = _user_model("panda", tmp_path)
    cal = tmp_path / "cal.csv"
    _simulate(model, cal, "--poses", 70, "--seed", 3)
    assert main(["--quiet", "calibrate", "--robot", model, str(cal), "-o", str(tmp_path / "c.yaml")]) == 0
    nominal = rc.load_model(model)
    q = nominal.limits.mean(axis=1) + np.linspace(0.0, 0.3, 4)[:, None]
    T = nominal.fk(q)
    rpy = Rotation.from_matrix(T[:, :3, :3]).as_euler("xyz", degrees=True)
    rows = [",".join(f"{v:.9f}" for v in np.r_[T[i, :3, 3] * 1e3, rpy[i]]) for i in range(len(T))]
    (tmp_path / "targets.csv").write_text("x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg\n" + "\n".join(rows) + "\n")
    argv = ["compensate", tmp_path / "c.yaml", tmp_path / "targets.csv", "--nominal", model]
    code, said = _run([*argv, "-o", tmp_path / "none.csv"], capsys)
    assert code == 2 and "give the joints the robot is at before the first target (--start" in said, said
    start = ",".join(f"{v:.4f}" for v in np.rad2deg(q[0] - 0.05))
    code, said = _run([*argv, f"--start={start}", "-o", tmp_path / "cmd.csv"], capsys)
    assert code == 0 and "not reached" not in said, said
    lines = [ln for ln in (tmp_path / "cmd.csv").read_text().splitlines() if not ln.startswith("#")]
    joints = np.deg2rad(np.array([[float(v) for v in ln.split(",")[:7]] for ln in lines[1:]]))
    calibrated = rc.load_model(str(tmp_path / "c.yaml")).with_frames(base=nominal.base, tool=nominal.tool)
    reached = calibrated.fk(joints)
    assert np.abs(reached[:, :3, 3] - T[:, :3, 3]).max() < 1e-6  # m: the calibrated flange on the targets


@pytest.mark.parametrize("robot", ["epson_g6_651s", "kuka_kr6_r700"])
def test_plane_contacts_with_the_default_probe_are_calibrated_to_their_noise(robot, tmp_path, capsys):
    """`simulate --kind plane` puts a probe tip ~100 mm off the flange: the KR6's were refused as
    implausible (28 mm from the nominal model with the tool at the flange), the G6's left 0.25 mm
    at zero noise (a start 100 mm off). The probe is fitted with the frames now: noise-free data fit
    to zero."""
    data = tmp_path / "planes.csv"
    _simulate(robot, data, "--poses", 80, "--kind", "plane", "--planes", 3, "--seed", 2, "--noise-mm", 0)
    code, said = _run(["calibrate", "--robot", robot, data, "-o", tmp_path / "c.yaml", "--json",
                       tmp_path / "r.json"], capsys)
    assert code == 0, said
    after = json.loads((tmp_path / "r.json").read_text())["after"]["rms"]
    assert after < 1e-3, said  # mm


def test_a_5_axis_arm_says_why_a_6_dof_target_is_not_reached(tmp_path, capsys):
    """A 5-axis arm's reachable poses are a 5-D set: the calibrated arm's is not the nominal's, so a
    nominal pose is generally not met exactly. Said so, with --start (it was 'use rc.ik.solve')."""
    model = _user_model("arm5", tmp_path)
    cal = tmp_path / "cal.csv"
    _simulate(model, cal, "--poses", 60, "--seed", 3)
    assert main(["--quiet", "calibrate", "--robot", model, str(cal), "-o", str(tmp_path / "c.yaml")]) == 0
    nominal = rc.load_model(model)
    q = nominal.limits.mean(axis=1) + np.linspace(0.0, 0.3, 3)[:, None]
    T = nominal.fk(q)
    rpy = Rotation.from_matrix(T[:, :3, :3]).as_euler("xyz", degrees=True)
    rows = [",".join(f"{v:.9f}" for v in np.r_[T[i, :3, 3] * 1e3, rpy[i]]) for i in range(len(T))]
    (tmp_path / "targets.csv").write_text("x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg\n" + "\n".join(rows) + "\n")
    start = ",".join(f"{v:.4f}" for v in np.rad2deg(q[0] - 0.05))
    code, said = _run(["compensate", tmp_path / "c.yaml", tmp_path / "targets.csv", "--nominal", model,
                       f"--start={start}", "-o", tmp_path / "cmd.csv"], capsys)
    assert code in (0, 1) and "a 5-joint arm reaches 5 of a pose's 6 freedoms" in said, said


def test_a_runtime_correction_with_nothing_to_route_is_said(nachi, tmp_path, capsys):
    """`filter --runtime-correction` on a program whose targets are all literals: corrected offline
    as before, and said that no routine is added (it was silent: a user counts on it)."""
    from robocal.kinematics.transforms import make_transform
    from robocal.programs.simulate import write_program

    nominal = rc.load_model(nachi["model"])
    q = np.deg2rad([[10, 20, -30, 5, 40, 15], [15, 25, -35, 0, 45, 10]])
    paths, tools, frames = write_program("krl", tmp_path, nominal, q, make_transform(np.eye(3), [0, 0, 0.2]),
                                         np.eye(4))
    given = [a for k, v in tools.items() for a in ("--tool", f"{k}={v}")] + \
        [a for k, v in frames.items() for a in ("--frame", f"{k}={v}")]
    (tmp_path / "out").mkdir()
    code, said = _run(["filter", *paths, "--calibrated", nachi["calibrated"], "--nominal", nachi["model"],
                       "-o", tmp_path / "out", "--runtime-correction", *given], capsys)
    assert code == 0 and "no motion of these files computes its target at run time" in said, said


def _user_model(family: str, folder: Path) -> str:
    """The model of ``family`` as a user gives it: a catalog name or a model file in ``folder``."""
    if family == "g6":
        return "epson_g6_651s"
    if family == "comau":
        return _mdh_file(folder / "comau.yaml", "comau_nj220", _COMAU_N220, 220)
    text = Path(__file__).with_name("test_workflow_mistakes.py").read_text()  # its Panda and 5-axis files
    key = {"panda": "PANDA_YAML", "arm5": "ARM5_YAML"}[family]
    (folder / f"{family}.yaml").write_text(re.search(key + r' = """\\\n(.*?)"""', text, re.S).group(1))
    return str(folder / f"{family}.yaml")


@pytest.mark.parametrize("family", ["comau", "panda", "g6", "arm5"])
def test_clean_campaigns_of_new_families_raise_no_warning(family, tmp_path, capsys):
    """The clean cases: a calibration with a validation of the same day, then a check of the
    unchanged robot: no warning, the check holds."""
    model = _user_model(family, tmp_path)
    cal = tmp_path / "cal.csv"
    truth = _simulate(model, cal, "--poses", 70, "--seed", 3)
    val = _moved(truth, tmp_path / "val.csv", 30, 11)
    code, said = _run(["calibrate", "--robot", model, cal, "--validate", val, "-o", tmp_path / "c.yaml",
                       "--json", tmp_path / "r.json"], capsys)
    assert code == 0 and "WARNING" not in said and "warning" not in said, said
    check = _moved(truth, tmp_path / "check.csv", 20, 21)
    code, said = _run(["check", tmp_path / "c.yaml", check, "--result", tmp_path / "r.json"], capsys)
    assert code == 0 and ": holds" in said, said
