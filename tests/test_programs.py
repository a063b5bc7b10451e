"""Robot program filtering: configuration <-> branch mapping, notations, the four vendor formats on
hand-written programs (byte-identical round trip, only numbers change), simulated truth, bad input."""

from __future__ import annotations

import csv
import io
import json
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.ik.opw_ik import branch_slot
from robocal.kinematics.catalog import catalog_names
from robocal.kinematics.transforms import rotvec_to_matrix
from robocal.programs import FilterResult, filter_program, source
from robocal.programs.dialects.fanuc.configuration import FANUCConfig
from robocal.programs.dialects.inform.configuration import YaskawaConfig
from robocal.programs.dialects.krl.configuration import KUKAConfig
from robocal.programs.dialects.rapid.configuration import ABBConfig
from robocal.programs.registry import dialect_named
from robocal.programs.rotations import matrix_to_quat, matrix_to_zyx, nearest_rotvec, quat_to_matrix
from robocal.programs.simulate import execute
from robocal.programs.source import NUMBER_RE, Number, format_number

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))  # the simulated-truth experiment
from bench_filter import truth_experiment  # noqa: E402

DATA = Path(__file__).parent / "data" / "programs"
OPW_ROBOTS = [n for n in catalog_names() if rc.Robot.from_catalog(n).opw]

# the hand-written programs: robot, files, references, controller frames/tools not in the files
FIXTURES = {
    "rapid": ("abb_irb2600", ["weld_cell.mod"], [], {}, {}),
    "krl": ("kuka_kr16_2", ["palletize.src", "palletize.dat"], ["config.dat"], {}, {}),
    "fanuc": ("fanuc_lrmate200id", ["sealing.ls"], [], {"1": "450,-150,100,0,0,-10"}, {"2": "0,0,120,0,0,0"}),
    "urscript": ("ur5", ["pick_place.script"], [], {}, {}),
}


def _fixture(name, tmp_path):
    robot, files, refs, frames, tools = FIXTURES[name]
    for f in files + refs:
        shutil.copy(DATA / f, tmp_path / f)
    return (rc.Robot.from_catalog(robot), [tmp_path / f for f in files], [tmp_path / f for f in refs],
            frames, tools)


# ----------------------------------------------------------------------------- configuration
@pytest.mark.parametrize("name", OPW_ROBOTS)
def test_branch_slot_is_the_closed_form_slot(name):
    robot = rc.Robot.from_catalog(name)
    q = np.random.default_rng(1).uniform(robot.limits[:, 0], robot.limits[:, 1], (500, 6))
    sols = rc.ik.solve_all(robot, robot.fk(q))
    picked = sols[np.arange(len(q)), branch_slot(robot.opw, q)]
    assert np.abs(np.remainder(picked - q + np.pi, 2 * np.pi) - np.pi).max() < 1e-7


@pytest.mark.parametrize("scheme", [ABBConfig(), KUKAConfig(), FANUCConfig()], ids=lambda s: s.name)
@pytest.mark.parametrize("name", OPW_ROBOTS)
def test_configuration_data_select_the_joints(name, scheme):
    """config_of(q) picks, among all closed-form candidates and their turns, exactly q."""
    robot = rc.Robot.from_catalog(name)
    if isinstance(scheme, KUKAConfig) and (np.abs(robot.limits) > np.pi * 2).any():
        pytest.skip("KUKA's sign bits tell turns apart only within +-360 deg")
    if not isinstance(scheme, KUKAConfig) and (np.diff(robot.limits[[1, 2, 4]], axis=1) > 2 * np.pi).any():
        # the ROS-I FANUC M-20iA and M-710iC/50 give J3 more than a turn (the union of its ranges
        # over J2, FANUC's J2/J3 coupling undone): ABB and FANUC data carry turns of J1, J4, J6 only
        pytest.skip("a joint whose turn the configuration data do not carry has more than 360 deg of travel")
    q = np.random.default_rng(2).uniform(robot.limits[:, 0], robot.limits[:, 1], (400, 6))
    cands = rc.ik.solve_all(robot, robot.fk(q), extra_turns=True)
    valid = np.isfinite(cands).all(axis=2)
    have = scheme.encode(robot, np.where(valid[..., None], cands, 0.0))
    score = np.where(valid, scheme.score(have, scheme.encode(robot, q)[:, None]), 10**9)
    assert (score.min(axis=1) == 0).all()
    picked = cands[np.arange(len(q)), score.argmin(axis=1)]
    assert np.abs(picked - q).max() < 1e-7


@pytest.mark.parametrize("name", [n for n in OPW_ROBOTS if n.startswith("yaskawa")])
def test_yaskawa_form_selects_the_joints(name):
    """RCONF of q picks q among the candidates within +-360 deg (the flags tell two copies apart),
    and the copy within a turn before one beyond it."""
    robot = rc.Robot.from_catalog(name)
    scheme = YaskawaConfig()
    lim = np.clip(robot.limits, -2 * np.pi + 1e-3, 2 * np.pi - 1e-3)
    q = np.random.default_rng(2).uniform(lim[:, 0], lim[:, 1], (400, 6))
    cands = rc.ik.solve_all(robot, robot.fk(q), extra_turns=True)
    valid = np.isfinite(cands).all(axis=2)
    have = scheme.encode(robot, np.where(valid[..., None], cands, 0.0))
    score = np.where(valid, scheme.score(have, scheme.encode(robot, q)[:, None]), 10**9)
    assert (score.min(axis=1) == 0).all()
    assert np.abs(cands[np.arange(len(q)), score.argmin(axis=1)] - q).max() < 1e-7
    home = scheme.encode(robot, np.deg2rad([[0, 0, 0, 0, -90, 0], [190, 0, 0, -200, 30, 400]]))
    assert [scheme.text(r) for r in home] == ["1,0,0,0,0,0", "0,0,0,1,1,1"]
    assert home[1, 4] == 2  # T at 400 deg: beyond a turn


def test_vendor_configuration_conventions():
    """Zero-pose conventions: ABB cfx 0, KUKA S bit 1 set at home, FANUC 'N U T'."""
    abb, kuka, fanuc = (rc.Robot.from_catalog(n) for n in ("abb_irb2600", "kuka_kr16_2", "fanuc_lrmate200id"))
    assert ABBConfig().encode(abb, np.deg2rad([[100, 0, 0, -10, 30, 200]])).tolist() == [[0, 1, -1, 2]]
    assert ABBConfig().encode(abb, np.deg2rad([[0, 0, 0, 0, -30, 0]]))[0, 0] == 1  # axis 5 negative
    assert KUKAConfig().encode(kuka, np.deg2rad([[0, -90, 90, 0, 30, 0]])).tolist() == [[2, 2]]
    negative = 1 + 2 + 8 + 16  # A1, A2, A4, A5 < 0
    assert KUKAConfig().encode(kuka, np.deg2rad([[-10, -90, 90, -5, -30, 20]])).tolist() == [[6, negative]]

    def fanuc_text(q_deg):
        return FANUCConfig().text(FANUCConfig().encode(fanuc, np.deg2rad([q_deg]))[0])

    assert fanuc_text([0, 0, 0, 0, -90, 0]) == "N U T, 0, 0, 0"
    assert fanuc_text([190, 0, 0, 0, 30, -200]) == "F U T, 1, 0, -1"


# ----------------------------------------------------------------------------- notations
def _zyx_matrix(abc_deg):
    """R = Rz(a) Ry(b) Rx(c) of ZYX Euler angles ``(N, 3)`` deg, as KUKA and FANUC read them."""
    return Rotation.from_euler("ZYX", abc_deg, degrees=True).as_matrix()


@settings(max_examples=200, deadline=None)
@given(st.floats(-180, 180), st.floats(-89.9, 89.9), st.floats(-180, 180))
def test_zyx_round_trip(a, b, c):
    abc = np.array([[a, b, c]])
    back = matrix_to_zyx(_zyx_matrix(abc), abc)
    assert np.abs(np.remainder(back - abc + 180, 360) - 180).max() < 1e-7


@settings(max_examples=200, deadline=None)
@given(st.floats(-180, 180), st.floats(-90, -89.99), st.floats(-180, 180), st.floats(-0.05, 0.05),
       st.floats(-1e-3, 1e-3), st.floats(-1e-3, 1e-3))
def test_zyx_near_gimbal_lock_keeps_the_files_numbers(a, b, c, turn, tilt_x, tilt_y):
    """Near P = -90 deg a turn about the pole plus a tilt: the triple represents the rotation within
    the tolerance, is never farther from the old numbers than the exact one, and keeps the old a
    whenever the tilt off the old a's plane is below the tolerance and c, taking the turn, stays
    within +-180 deg (a c beyond it is not writable; then a takes the turn)."""
    old = np.array([[a, b, c]])
    R = Rotation.from_rotvec(np.deg2rad([tilt_x, tilt_y, turn])).as_matrix() @ _zyx_matrix(old)
    tol = 5e-4
    got = matrix_to_zyx(R, old, tol)
    exact = matrix_to_zyx(R, old)
    err = np.rad2deg(np.linalg.norm(Rotation.from_matrix(_zyx_matrix(got)[0].T @ R[0]).as_rotvec()))
    assert err <= tol + 1e-9
    assert np.abs(got - old).sum() <= np.abs(exact - old).sum() + tol
    assert np.abs(got).max() <= 180.0
    if max(abs(tilt_x), abs(tilt_y)) < tol / 2 and abs(c) + abs(turn) + tol < 180.0:
        assert abs(got[0, 0] - a) < 1e-9


def test_notations_keep_the_old_form():
    rng = np.random.default_rng(3)
    q = rng.standard_normal((50, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    assert np.allclose(matrix_to_quat(quat_to_matrix(q), q), q)
    assert np.allclose(matrix_to_quat(quat_to_matrix(-q), -q), -q)
    # gimbal lock: a keeps its value, c takes the rest; off it, scipy's matrix agrees
    g = np.array([[30.0, 90.0, 10.0], [-40.0, -90.0, 25.0]])
    assert np.allclose(matrix_to_zyx(_zyx_matrix(g), g), g)
    r = np.array([[0.0, 0.0, np.pi - 1e-9], [0.0, 3.0, 0.0]])
    old = np.array([[0.0, 0.0, -np.pi], [0.0, 3.0, 0.0]])  # the complement of the first
    got = nearest_rotvec(rotvec_to_matrix(r), old)
    assert np.allclose(got, [[0, 0, -np.pi - 1e-9], [0, 3, 0]], atol=1e-8)
    assert np.allclose(rotvec_to_matrix(got), rotvec_to_matrix(r))


def test_format_number():
    old = Number(0, 6, "500.00")
    assert format_number(500.0004, old, 1e-3) == "500.00"  # within half the resolution: unchanged
    assert format_number(500.123456, old, 1e-3) == "500.123"  # more decimals where needed
    assert format_number(500.12, Number(0, 8, "500.0000"), 1e-3) == "500.1200"  # the file's decimals
    assert format_number(-0.0001, Number(0, 1, "3"), 1e-3) == "0.000"  # never -0
    assert format_number(2.5, Number(0, 2, "+1"), 1e-3) == "+2.500"


# ----------------------------------------------------------------------------- the four formats
def _numbers_masked(data: bytes) -> str:
    return NUMBER_RE.sub("#", data.decode("latin-1"))


@pytest.mark.parametrize("fmt", list(FIXTURES))
def test_identity_is_byte_identical(fmt, tmp_path):
    robot, files, refs, frames, tools = _fixture(fmt, tmp_path)
    res = filter_program(files, robot, robot, frames=frames, tools=tools, references=refs)
    assert all(res.outputs[p] == p.read_bytes() for p in files)
    assert all(r["correction_mm"] < 1e-6 and r["configuration"] != "changed" for r in res.rows)


@pytest.mark.parametrize("fmt", list(FIXTURES))
def test_hand_written_program_lands_on_its_targets(fmt, tmp_path):
    """With a model of the true robot, the filtered program puts the true robot on the program's
    targets; only numbers change; CRLF line endings and the inputs are kept."""
    nominal, files, refs, frames, tools = _fixture(fmt, tmp_path)
    before = {p: p.read_bytes() for p in files}
    true = perturbed(nominal, 7)
    res = filter_program(files, true, nominal, frames=frames, tools=tools, references=refs)
    expected = {"rapid": 5, "krl": 5, "fanuc": 6, "urscript": 5}[fmt]
    assert len(res.rows) == expected and all(r["filtered"] for r in res.rows)
    out = []
    for p in files:
        data = res.outputs[p]
        assert data != before[p] and p.read_bytes() == before[p]
        assert _numbers_masked(data) == _numbers_masked(before[p])
        assert data.count(b"\r\n") == before[p].count(b"\r\n")
        o = tmp_path / "out" / p.name
        o.parent.mkdir(exist_ok=True)
        o.write_bytes(data)
        out.append(o)
    reached, X = execute(out, true, nominal, frames=frames, tools=tools, references=refs)
    unfiltered, X0 = execute(files, true, nominal, frames=frames, tools=tools, references=refs)
    err = np.linalg.norm(reached[:, :3, 3] - X0[:, :3, 3], axis=1) * 1e3
    err0 = np.linalg.norm(unfiltered[:, :3, 3] - X0[:, :3, 3], axis=1) * 1e3
    assert err.max() < 0.005 and err0.min() > 0.3  # written to 1 um; the robot was 0.3-2 mm off


def test_rapid_details(tmp_path):
    robot, files, *_ = _fixture("rapid", tmp_path)
    res = filter_program(files, perturbed(robot, 7), robot)
    names = [r["name"] for r in res.rows]
    assert names == ["pApproach", "pSeamStart", "pSeam{1}", "pSeam{2}", "inline@40"]
    assert {r["tool"] for r in res.rows} == {"tgun"} and {r["frame"] for r in res.rows} == {"wtable"}
    text = res.outputs[files[0]].decode()
    # the commented-out target, the string and the jointtarget are untouched
    assert "pOld:=[[1,2,3],[1,0,0,0]" in text and '"Weld seam 1 [left] ! done"' in text
    assert "jHome:=[[0,0,0,0,30,0]" in text
    summary = res.summary()
    assert "5 of 5" in summary and "correction" in summary


def test_urscript_variable_is_its_latest_assignment():
    """A motion through a variable takes the variable's last assignment before it in text order,
    whatever other names share its prefix; a use before any assignment is not a target."""
    from robocal.programs.dialects.urscript.reader import URScriptDialect
    from robocal.programs.source import ProgramText

    text = b"""def prog():
  movel(Waypoint_1_p, a=1.2, v=0.25)
  global Waypoint_1_p=p[0.1, 0.2, 0.3, 0, 3.1, 0]
  global Waypoint_10_p=p[0.4, 0.5, 0.6, 0, 3.1, 0]
  movel(Waypoint_1_p, a=1.2, v=0.25)
  Waypoint_1_p=p[0.7, 0.8, 0.9, 0, 3.1, 0]
  movel(Waypoint_10_p, a=1.2, v=0.25)
  movel(Waypoint_1_p, a=1.2, v=0.25)
  movel(Waypoint_10_p, a=1.2, v=0.25)
end
"""
    prog = URScriptDialect().parse([ProgramText("prog.script", text)], {}, {"default": np.eye(4)})
    assert [t.line for t in prog.targets] == [3, 4, 6]
    assert np.allclose([t.values()[:3] for t in prog.targets], [[0.1, 0.2, 0.3], [0.4, 0.5, 0.6],
                                                                [0.7, 0.8, 0.9]])


# ----------------------------------------------------------------------------- simulated truth
@pytest.mark.parametrize("fmt,robot", [("rapid", "abb_irb2600"), ("krl", "kuka_kr16_2"),
                                       ("fanuc", "fanuc_lrmate200id"), ("urscript", "ur5")])
def test_filter_on_simulated_truth(fmt, robot, tmp_path):
    """200 targets with a work object and a real tool (TCP identified on the calibrated model):
    the filtered program is within 1.2x of a perfect filter and 10x better than unfiltered."""
    r = truth_experiment(fmt, robot, n_targets=200, seed=3, folder=tmp_path)
    assert r["targets"] == 200
    f, u, p = r["filtered"], r["unfiltered"], r["perfect"]
    assert f["rms_mm"] <= 1.2 * p["rms_mm"] and f["max_mm"] <= 1.2 * p["max_mm"] + 0.002
    assert 10 * f["rms_mm"] <= u["rms_mm"]
    assert f["rms_deg"] <= 1.2 * p["rms_deg"] < u["rms_deg"]


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("old,new,match", [
    (b"[[392.37,421.20,120.43]", b"[[392.37,421.20,,120.43]",
     r"bad.mod:14: malformed robtarget pApproach: empty item"),
    (b"[[392.37,421.20,120.43]", b"[[392.37,421.20]",
     r"bad.mod:14: malformed robtarget pApproach: expected groups"),
    (b"z1, tGun \\WObj", b"z1, tNone \\WObj",
     r"unknown tool 'tnone' \(2 places: bad.mod:\d+ \(pSeam\{1\}\), bad.mod:\d+ \(pSeam\{2\}\)\)"),
], ids=["empty item", "short group", "unknown tool"])  # one target with two tools: named (test_real_programs)
def test_malformed_and_unknown(old, new, match, tmp_path):
    robot, files, *_ = _fixture("rapid", tmp_path)
    bad = tmp_path / "bad.mod"
    data = files[0].read_bytes()
    assert old in data
    bad.write_bytes(data.replace(old, new))
    with pytest.raises(DataError, match=match):
        filter_program(bad, robot, robot)


def test_unreachable_and_impossible_configuration(tmp_path):
    robot, files, *_ = _fixture("rapid", tmp_path)
    data = files[0].read_bytes()
    bad = tmp_path / "far.mod"
    bad.write_bytes(data.replace(b"[[392.37,421.20,120.43]", b"[[3392.37,421.20,120.43]"))
    with pytest.raises(DataError, match=r"far.mod:14 \(pApproach\): no solution .*\(out of reach\)"):
        filter_program(bad, robot, robot)
    res = filter_program(bad, perturbed(robot, 1), robot, keep_unreached=True)
    assert b"[[3392.37,421.20,120.43]" in res.outputs[bad]
    assert any("left unchanged" in w for w in res.warnings) and not res.rows[0]["filtered"]
    # pApproach in the 'behind axis 1' configuration: not inside the IRB 2600's limits
    bad.write_bytes(data.replace(b"[0,0,-1,0],[9E+09", b"[0,0,-1,4],[9E+09", 1))
    with pytest.raises(DataError, match=r"pApproach\): configuration \[0,0,-1,4\] is not possible"):
        filter_program(bad, robot, robot)


def test_table_json_holds_every_field_one_target_per_line(tmp_path):
    """The table JSON (written row by row for speed) parses to the same content as a plain dump."""
    from dataclasses import asdict

    robot, files, *_ = _fixture("rapid", tmp_path)
    res = filter_program(files[0], perturbed(robot, 7), robot)
    text = res.table_json()
    expected = {"dialect": res.dialect, "files": [str(p) for p in res.outputs], "summary": res.summary_dict(),
                "loads": res.loads, "warnings": res.warnings, "targets": res.rows,
                "motions": [asdict(m) for m in res.motions]}
    assert json.loads(text) == json.loads(json.dumps(expected))
    lines = {ln.strip().rstrip(",") for ln in text.splitlines()}
    assert len(res.rows) == 5 and all(json.dumps(r) in lines for r in res.rows)


def test_cli_filter_writes_all_or_nothing(tmp_path, capsys):
    robot, files, *_ = _fixture("rapid", tmp_path)
    cal = tmp_path / "cal.yaml"
    perturbed(robot, 7).save(cal)
    out = tmp_path / "weld_cal.mod"
    args = ["filter", str(files[0]), "--calibrated", str(cal), "--nominal", "abb_irb2600", "-o", str(out)]
    assert main(args) == 0
    assert "5 of 5 Cartesian target(s) filtered" in capsys.readouterr().out
    table = json.loads((tmp_path / "weld_cal.mod.targets.json").read_text())
    assert len(table["targets"]) == 5 and table["summary"]["filtered"] == 5
    assert (tmp_path / "weld_cal.mod.targets.csv").read_text().count("\n") == 6
    # an unreachable target: exit 2, message names file, line and target, nothing written
    far = tmp_path / "far.mod"
    far.write_bytes(files[0].read_bytes().replace(b"[[392.37,421.20,120.43]", b"[[3392.37,421.20,120.43]"))
    out2 = tmp_path / "far_cal.mod"
    assert main(["filter", str(far), "--calibrated", str(cal), "--nominal", "abb_irb2600",
                 "-o", str(out2)]) == 2
    assert "far.mod:14 (pApproach)" in capsys.readouterr().err
    assert not out2.exists() and not list(tmp_path.glob("far_cal*")) and not list(tmp_path.glob(".*tmp"))
    # never onto an input
    assert main(args[:-1] + [str(files[0])]) == 2
    assert "never overwrites its inputs" in capsys.readouterr().err


def test_cli_filter_kuka_folder_and_fanuc_frames(tmp_path, capsys):
    robot, files, refs, *_ = _fixture("krl", tmp_path)
    cal = tmp_path / "cal.yaml"
    perturbed(robot, 7).save(cal)
    outdir = tmp_path / "filtered"
    outdir.mkdir()
    assert main(["filter", *map(str, files), "--references", str(refs[0]), "--calibrated", str(cal),
                 "--nominal", "kuka_kr16_2", "-o", str(outdir)]) == 0
    assert sorted(p.name for p in outdir.iterdir()) == [
        "palletize.dat", "palletize.src", "palletize.targets.csv", "palletize.targets.json"]
    fan, ffiles, *_ = _fixture("fanuc", tmp_path)
    # the FANUC user and tool frames live in the controller: without them the filter says so
    assert main(["filter", str(ffiles[0]), "--calibrated", str(cal), "--nominal", "fanuc_lrmate200id",
                 "-o", str(tmp_path / "s.ls")]) == 2
    assert "unknown frame '1'" in capsys.readouterr().err


# ----------------------------------------------------------------------------- boundaries and warnings
def _program(tmp_path, dialect, robot, q, name="edge"):
    from robocal.programs.simulate import write_program

    tool = np.eye(4)
    tool[:3, 3] = [0.02, 0.0, 0.1]
    folder = tmp_path / name
    folder.mkdir()
    return write_program(dialect, folder, robot, np.deg2rad(q), tool, np.eye(4), name)


def test_configuration_rewritten_only_across_a_boundary(tmp_path):
    """Axis 4 taught at +-0.001 deg: where the correction takes it to the other side of zero, cf4
    changes quadrant with a warning; elsewhere the data stay as written."""
    robot = rc.Robot.from_catalog("abb_irb2600")
    q = np.array([[10 + 5 * k, 20 + 3 * k, 10 - 4 * k, 0.001 * (-1) ** k, 40 + 5 * k, -20 + 10 * k]
                  for k in range(12)])
    paths, _, _ = _program(tmp_path, "rapid", robot, q)
    res = filter_program(paths, perturbed(robot, 0), robot)
    changed = [r for r in res.rows if r["configuration"] == "changed"]
    assert len(changed) == 6 and sum(r["configuration"] == "kept" for r in res.rows) == 6
    lines = res.outputs[paths[0]].decode().splitlines()
    for r in changed:
        before, after = (list(map(int, r[k].strip("[]").split(","))) for k in ("config_before",
                                                                                "config_after"))
        assert after[1] == before[1] - 1 and after[0] == before[0] and after[2:] == before[2:]  # only cf4
        assert f",[{r['config_after'].strip('[]')}],[9E+09" in lines[r["line"] - 1]
        message = f"({r['name']}): configuration changed from {r['config_before']} to {r['config_after']}"
        assert any(message in w for w in res.warnings)
    for r in res.rows:
        if r["configuration"] == "kept":
            assert f",[{r['config_before'].strip('[]')}],[9E+09" in lines[r["line"] - 1]


def test_near_singular_targets_are_named(tmp_path):
    robot = rc.Robot.from_catalog("kuka_kr16_2")
    q = np.array([[10, -80, 100, 10, 40, -20], [15, -70, 95, 30, 0.2, 10]])
    paths, tools, frames = _program(tmp_path, "krl", robot, q)
    res = filter_program(paths, perturbed(robot, 2), robot, tools=tools, frames=frames)
    assert res.rows[1]["nearest_singularity"] == "wrist" and res.rows[1]["sigma_rel"] < 0.01
    assert res.rows[0]["sigma_rel"] > 0.01
    assert [w for w in res.warnings if "singularity" in w] == [
        w for w in res.warnings if "(XP1): close to a singularity, nearest the wrist singularity" in w]
    assert "nearest singularity: XP1 (wrist" in res.summary()


def test_out_of_the_limits_after_correction(tmp_path):
    """A target taught at a joint limit: corrected joints beyond it are an error naming target and joint."""
    robot = rc.Robot.from_catalog("fanuc_lrmate200id")
    lim = np.rad2deg(robot.limits)
    q = np.array([[0, 10, 10, 0, -40, 0]] * 4, float)
    q[0, 0], q[1, 0], q[2, 4], q[3, 4] = lim[0, 1], lim[0, 0], lim[4, 1], lim[4, 0]
    paths, tools, frames = _program(tmp_path, "fanuc", robot, q)
    with pytest.raises(DataError, match=r"edge.ls:\d+ \(P\[\d\]\): the corrected joints leave the limits "
                                        r"\(joint [15] by"):
        filter_program(paths, perturbed(robot, 3), robot, tools=tools, frames=frames)
    # kept unchanged instead: 'reachable' says the nominal controller has joints for the target
    # (the one whose correction leaves the limits), not that it was filtered
    res = filter_program(paths, perturbed(robot, 3), robot, tools=tools, frames=frames, keep_unreached=True)
    assert any(r["reachable"] and not r["filtered"] for r in res.rows)
    assert any(not r["reachable"] for r in res.rows) and any(r["filtered"] for r in res.rows)


def test_table_csv_quotes_cells():
    """Cells holding a comma or a double quote (a file name may) survive the CSV table."""
    row = {"file": 'we"ld, cell.mod', "line": 3, "name": "p1", "correction_mm": 0.5}
    text = FilterResult("ABB RAPID", {}, [row]).table_csv()
    assert list(csv.DictReader(io.StringIO(text))) == [
        {"file": 'we"ld, cell.mod', "line": "3", "name": "p1", "correction_mm": "0.5"}]


def test_robot_base_given_explicitly(tmp_path):
    """--robot-base = the controller's base in the tracker frame gives what the default (identified
    frame {0} = controller base) gives when it is that frame."""
    robot, files, *_ = _fixture("rapid", tmp_path)
    cal = perturbed(robot, 7).with_frames(base=TRACKER)
    a = filter_program(files, cal, robot)
    b = filter_program(files, cal, robot, robot_base=TRACKER)
    c = filter_program(files, cal, robot, robot_base=TRACKER @ _shift(0.001))
    assert a.outputs == b.outputs and a.outputs != c.outputs


def _shift(metres):
    T = np.eye(4)
    T[0, 3] = metres
    return T


TRACKER = np.array([[0.0, -1.0, 0.0, 2.5], [1.0, 0.0, 0.0, -0.4], [0.0, 0.0, 1.0, 0.3], [0.0, 0.0, 0.0, 1.0]])


def test_krl_needs_the_tool_and_base_in_effect(tmp_path):
    robot, files, refs, *_ = _fixture("krl", tmp_path)
    src = files[0].read_bytes().replace(b"  $TOOL = TOOL_DATA[2]\r\n", b"")
    src = src.replace(b"FDAT_ACT=FP1", b"FDAT_ACT=FUNKNOWN")
    files[0].write_bytes(src)
    res = filter_program(files, robot, robot, references=refs)
    assert "XP1" not in [r["name"] for r in res.rows]
    expected = r"palletize.src:\d+: PTP: not corrected: XP1: FDAT_ACT=FUNKNOWN names no FDAT .*"
    assert any(re.fullmatch(expected, w) for w in res.uncorrected)
    assert "1 not corrected (each named)" in res.summary()


def test_krl_and_fanuc_configuration_edits():
    from robocal.programs.dialects.fanuc.reader import FanucDialect
    from robocal.programs.dialects.krl.reader import KRLDialect
    from robocal.programs.model import Target
    from robocal.programs.source import ProgramText

    src = ProgramText("x.dat", b"S 'B1010',T 35")
    t = Target(src, 0, "P", [], config_spans=(Number(2, 9, "'B1010'"), Number(12, 14, "35")))
    # bit 3 of S is kept, bits 0-2 come from the joints; T written as a decimal
    assert KRLDialect().config_edits(t, np.array([6, 3])) == {(2, 9): "'B1110'", (12, 14): "3"}
    ls = ProgramText("x.ls", b"'N U T, 0, 0, 0'")
    spans = [(1, 2, "N"), (3, 4, "U"), (5, 6, "T"), (8, 9, "0"), (11, 12, "0"), (14, 15, "0")]
    t = Target(ls, 0, "P[1]", [], config_spans=spans)
    assert FanucDialect().config_edits(t, np.array([1, 0, 0, 0, -1, 0])) == {(1, 2): "F", (11, 12): "-1"}
    assert ls.replaced({(1, 2): "F", (11, 12): "-1"}) == b"'F U T, 0, -1, 0'"


def test_a_robot_that_is_not_six_axis_is_refused():
    arm7 = rc.Robot.from_mdh(alpha=[0, -90, 90, 90, -90, 90, 90], a=[0, 0, 0, 82.5, -82.5, 0, 88],
                             theta=[0] * 7, d=[333, 0, 316, 0, 384, 0, 107], degrees=True, length_unit="mm")
    with pytest.raises(DataError, match="6-axis arms; the nominal model .* has 7 joints"):
        filter_program(DATA / "pick_place.script", arm7, arm7)


# ----------------------------------------------------------------------------- execution order
def _controller(paths, robot, tools=None, frames=None):
    """Target names in the filter's order, their flange poses and the filter's controller joints."""
    from robocal.kinematics.transforms import invert_transform
    from robocal.programs.filter import as_frames, controller_joints, target_poses
    from robocal.programs.registry import dialect_for
    from robocal.programs.source import ProgramText

    d = dialect_for(paths)
    program = d.parse([ProgramText(p) for p in paths], as_frames(d, frames or {}), as_frames(d, tools or {}))
    _, P, W, tool = target_poses(d, program, program.targets)
    F = W @ P @ invert_transform(tool)
    problems, warnings = [], []
    q = controller_joints(d, program, program.targets, robot, F, problems, warnings)
    assert not problems
    return [t.name for t in program.targets], F, q, program.warnings + warnings


def _nearest_by_hand(robot, F, prev, power):
    """The controller's choice computed by hand: among all closed-form solutions inside the limits
    (rc.ik.solve_all with the turn copies), the one nearest ``prev`` (sum of |dq|**power)."""
    cands = rc.ik.solve_all(robot, F[None], extra_turns=True)[0]
    d = np.where(np.isfinite(cands).all(axis=1), (np.abs(cands - prev) ** power).sum(axis=1), np.inf)
    return cands[int(np.argmin(d))]


def test_urscript_targets_are_chained_in_execution_order(tmp_path):
    """A def with movel targets written before the main code that calls it after a far movej: the
    controller reaches them from the movej's joints (not from zero joints, their text order); a
    second call coming from other joints, where the controller takes another branch, is named."""
    robot = rc.Robot.from_catalog("ur5")
    q_far = np.array([1.2, -2.0, 2.0, -1.5, -1.4, 0.5])
    T = robot.fk(np.array([q_far + 0.05, q_far + 0.1]))
    pose = [", ".join(f"{v:.6f}" for v in (*t[:3, 3], *Rotation.from_matrix(t[:3, :3]).as_rotvec()))
            for t in T]
    q_other = _nearest_by_hand(robot, T[0], np.zeros(6), 2)  # the branch zero joints would give
    joints = [", ".join(f"{v:.6f}" for v in q) for q in (q_far, q_other)]
    path = tmp_path / "order.script"
    path.write_text(f"def approach():\n  movel(p[{pose[0]}], a=1.2, v=0.25)\n"
                    f"  movel(p[{pose[1]}], a=1.2, v=0.25)\nend\nmovej([{joints[0]}], a=1.4, v=1.05)\n"
                    f"approach()\nmovej([{joints[1]}], a=1.4, v=1.05)\napproach()\n")
    names, F, q, warnings = _controller([path], robot)
    assert names == ["p@2", "p@3"]
    q_a = _nearest_by_hand(robot, F[0], q_far, 2)
    np.testing.assert_allclose(q, [q_a, _nearest_by_hand(robot, F[1], q_a, 2)], atol=1e-9)
    assert np.abs(q_a - q_other).max() > 1.0  # text order (from zero joints) would take another branch
    assert any(re.match(r"order\.script:2 \(p@2\): executed again through the call at order\.script:8, .*"
                        r"first execution \(through order\.script:6\)", w) for w in warnings)
    assert not any("no joint position before the first target" in w for w in warnings)


def test_rapid_routine_before_main_is_chained_in_execution_order(tmp_path):
    """PROC path (ConfL\\Off) written before PROC main, which calls it after MoveJ pFar: the
    targets of path are solved nearest pFar's joints."""
    robot = rc.Robot.from_catalog("abb_irb2600")
    q_far = np.deg2rad([100, 40, 10, -120, 60, 150])
    (gen,), _, _ = _program(tmp_path, "rapid", robot, np.rad2deg([q_far, q_far + 0.05, q_far + 0.1]))
    decls = "\n".join(line for line in gen.read_text().splitlines() if re.match(r"\s*(PERS|CONST) ", line))
    move = "v500, fine, tReal\\WObj:=wCell;"
    path = tmp_path / "order.mod"
    path.write_text(f"MODULE order\n{decls}\n  PROC path()\n    ConfL\\Off;\n    MoveL p1, {move}\n"
                    f"    MoveL p2, {move}\n  ENDPROC\n  PROC main()\n    MoveJ p0, {move}\n    path;\n"
                    "  ENDPROC\nENDMODULE\n")
    names, F, q, _ = _controller([path], robot)
    assert names == ["p0", "p1", "p2"]
    np.testing.assert_allclose(q[0], q_far, atol=1e-4)  # the written numbers are rounded
    q_a = _nearest_by_hand(robot, F[1], q[0], 1)
    np.testing.assert_allclose(q[1:], [q_a, _nearest_by_hand(robot, F[2], q_a, 1)], atol=1e-9)
    assert np.abs(q_a - _nearest_by_hand(robot, F[1], np.zeros(6), 1)).max() > 1.0  # text order differs


def test_krl_subroutine_is_chained_in_execution_order(tmp_path):
    """A DEF after the main DEF of the .src, called between two targets on different wrist
    branches: its targets without S/T follow the one before the call, not the one before it in
    the text."""
    robot = rc.Robot.from_catalog("kuka_kr16_2")
    q_far = np.array([40, -60, 100, 60, -50, 30.0])
    q_end = np.array([40, -60, 100, -120, 50, -150.0])
    (src, dat), tools, frames = _program(tmp_path, "krl", robot, [q_far, q_far + 3, q_far + 6, q_end])
    dat.write_text(re.sub(r"(XP[12]=\{[^}]*?),S \d+,T \d+", r"\1", dat.read_text()))
    src.write_text("DEF edge( )\n  $TOOL = TOOL_DATA[1]\n  $BASE = BASE_DATA[1]\n  PTP XP0\n  PICK( )\n"
                   "  PTP XP3\nEND\n\nDEF PICK( )\n  LIN XP1\n  LIN XP2\nEND\n")
    names, F, q, _ = _controller([src, dat], robot, tools, frames)
    assert names == ["XP0", "XP1", "XP2", "XP3"]
    np.testing.assert_allclose(q[[0, 3]], np.deg2rad([q_far, q_end]), atol=1e-4)
    q_a = _nearest_by_hand(robot, F[1], q[0], 1)
    np.testing.assert_allclose(q[1:3], [q_a, _nearest_by_hand(robot, F[2], q_a, 1)], atol=1e-9)
    assert np.abs(q_a - _nearest_by_hand(robot, F[1], q[3], 1)).max() > 1.0  # text order differs


def test_no_entry_keeps_text_order_with_a_warning(tmp_path):
    """Two top-level defs and nothing calling either: the entry is unknown, text order is kept
    and said; a script without routines says nothing."""
    pose = "p[0.4, 0.1, 0.4, 0.0, 3.14, 0.0]"
    two = tmp_path / "two.script"
    two.write_text(f"def a():\n  movel({pose})\nend\ndef b():\n  movel({pose})\nend\n")
    flat = tmp_path / "flat.script"
    flat.write_text(f"movel({pose})\n")
    robot = rc.Robot.from_catalog("ur5")
    assert any("no entry routine found" in w for w in _controller([two], robot)[3])
    assert not any("no entry routine found" in w for w in _controller([flat], robot)[3])


def test_filter_program_returns_the_warnings_about_what_was_given():
    """The API says what the command line says: a --tool that differs from the program's own tool
    data, a payload / temperature the model has no term for; magnitudes in another unit refused."""
    nominal = rc.Robot.from_catalog("abb_irb2600")
    calibrated = perturbed(nominal, 0)
    res = filter_program(DATA / "weld_cell.mod", calibrated, nominal, payload=5.0, temperature=30.0,
                         tools={"tGun": "52,0,200,0.96592583,0,0.25881905,0"})
    assert res.warnings[0].startswith("--tool tGun=52,0,200,0.96592583,0,0.25881905,0 replaces the program's "
                                      "own tool data tGun (TCP at 50, 0, 200 mm on the flange) and differs "
                                      "from it by 2 mm")
    assert res.warnings[1:3] == ["--payload is not used: the model of abb_irb2600 has no payload term",
                                 "--temperature is not used: the model of abb_irb2600 has no thermal term"]
    with pytest.raises(DataError, match="the values look like metres"):
        filter_program(DATA / "weld_cell.mod", calibrated, nominal, robot_base="0.1,0,0,0,0,0.05")
    with pytest.raises(DataError, match="look like metres"):
        filter_program(DATA / "sealing.ls", calibrated, nominal, tools={"2": "0,0,0.12,0,0,0"})


@pytest.mark.parametrize(("key", "files", "references", "robot", "tool", "own"), [
    ("rapid", ["weld_cell.mod"], [], "abb_irb2600", {"tGun": "60,0,200,0.96592583,0,0.25881905,0"},
     "tGun (TCP at 50, 0, 200 mm"),
    ("krl", ["palletize.src", "palletize.dat"], ["config.dat"], "kuka_kr16_2", {"1": "0,0,150,0,0,0"},
     "1 (TCP at 0, 0, 250 mm")])
def test_a_tool_given_reads_each_file_once(key, files, references, robot, tool, own, monkeypatch):
    """With --tool, each file is masked and parsed once: that parse records the tool data the files
    hold (`Program.declared_tools`), which the --tool is checked against (a second parse without
    the overrides, masking every file again, did that before)."""
    dialect = type(dialect_named(key))
    parses, masks = [], []
    parse, mask = dialect.parse, source.mask

    def counted_parse(self, sources, *args):
        parses.append([s.path.name for s in sources])
        return parse(self, sources, *args)

    def counted_mask(text, *args):
        masks.append(text)
        return mask(text, *args)

    monkeypatch.setattr(dialect, "parse", counted_parse)
    monkeypatch.setattr(source, "mask", counted_mask)
    nominal = rc.Robot.from_catalog(robot)
    res = filter_program([DATA / f for f in files], perturbed(nominal, 0), nominal, tools=tool,
                         references=[DATA / r for r in references], keep_unreached=True)
    assert parses == [files]
    assert len(masks) == len(files) + len(references)  # the load reader shares the reader's masking
    name, text = next(iter(tool.items()))
    assert res.warnings[0].startswith(f"--tool {name}={text} replaces the program's own tool data {own}")
