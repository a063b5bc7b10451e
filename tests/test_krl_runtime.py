"""KRL run-time correction (``filter --runtime-correction``): the routine the filter adds is
EXECUTED by an evaluator of the KRL subset it uses (tests/krl_subset_eval.py, with the
controller's INVERSE emulated by the nominal model's closed-form IK honouring Status and Turn)
on the filtered program's run-time targets, and lands the true robot where robocal's offline
``compensate`` does; every other byte of the program is unchanged."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

import robocal as rc
from robocal.deploy.compensation import compensate, controller_model
from robocal.ik.closed_form import solve_all
from robocal.programs.dialects.krl.configuration import KUKAConfig
from robocal.programs.dialects.krl.runtime import (
    BEGIN,
    END,
    FRAME_FUNCTION,
    FUNCTION,
    KRLRuntime,
    frame_numbers,
)
from robocal.programs.runtime import calibrated_chain, reference_correction

sys.path.insert(0, str(Path(__file__).parent))
from krl_subset_eval import FIELDS, Machine, Struct, to_matrix  # noqa: E402

GOAL = 1.3  # the run-time correction lands within this times the calibrated model's own error
FLOAT32_MM = 0.005  # what KRL's 32-bit REALs may add to a landing (mm)
SCHEME = KUKAConfig()
NOMINAL = rc.Robot.from_catalog("kuka_kr16_2")
TOOL = np.array([[0.0, 0.0, 1.0, 0.012], [0.0, 1.0, 0.0, -0.004], [-1.0, 0.0, 0.0, 0.16], [0, 0, 0, 1]])
BASE = np.eye(4)
BASE[:3, 3] = [0.25, -0.1, 0.05]
OFFSETS = [(20.0, -10.0, 5.0, 3.0, -2.0, 4.0), (-35.0, 15.0, -25.0, -6.0, 4.0, 1.0),
           (0.0, 40.0, 10.0, 0.0, 0.0, -8.0)]  # run-time values of OFFS, mm and deg
Q = np.deg2rad([[25, -85, 95, 35, 45, -40], [-25, -70, 110, -40, -35, 60], [30, -95, 85, 60, 55, 40],
                [-30, -60, 100, -100, 25, 150]])  # axes 20 deg or more from 0: the offsets keep S and T


def _models():
    """(truth, calibrated): the real robot mm off the nominal; the calibration ~0.1 mm off it."""
    rng = np.random.default_rng(46)
    names = [n for n in NOMINAL.geometry_names if n[:-1] in ("a", "d", "alpha", "beta", "theta")]
    big = {n: NOMINAL.get(n) + rng.normal(0, 1e-3 if n[0] in "ad" else 1.5e-3) for n in names}
    truth = NOMINAL.with_values(big)
    small = {n: truth.get(n) + rng.normal(0, 5e-5 if n[0] in "ad" else 8e-5) for n in names}
    return truth, NOMINAL.with_values(small)


def _e6pos(T: np.ndarray, q: np.ndarray) -> str:
    v = frame_numbers(T[None])[0]
    s, t = SCHEME.encode(NOMINAL, q[None])[0]
    return (f"{{X {v[0]:.3f},Y {v[1]:.3f},Z {v[2]:.3f},A {v[3]:.4f},B {v[4]:.4f},C {v[5]:.4f},"
            f"S {s},T {t},E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}}")


def _program(folder: Path, newline: str = "\n") -> list[Path]:
    P = np.linalg.inv(BASE) @ NOMINAL.fk(Q) @ TOOL  # targets in BASE_DATA[1] with TOOL_DATA[1]
    src = ["DEF rtprog( )", "  DECL INT I", "  $TOOL = TOOL_DATA[1]", "  $BASE = BASE_DATA[1]",
           "  PTP XHOMEP", "  FOR I = 1 TO 3", "    OFFS.X = I * 20.0", "    LIN XP1:OFFS C_DIS",
           "    CIRC XP2:OFFS, XP3:OFFS CA 10.0", "  ENDFOR", "  PSTORE = $POS_ACT", "  LIN PSTORE",
           "  LIN XHOMEP:OFFS ; on a target corrected offline", "END", ""]
    dat = ["DEFDAT rtprog", f"DECL E6POS XHOMEP={_e6pos(P[0], Q[0])}",
           *[f"DECL E6POS XP{i}={_e6pos(P[i], Q[i])}" for i in (1, 2, 3)],
           "DECL FRAME OFFS={X 0.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}", "DECL E6POS PSTORE", "ENDDAT", ""]
    paths = [folder / "rtprog.src", folder / "rtprog.dat"]
    for p, lines in zip(paths, (src, dat), strict=True):
        p.write_bytes(newline.join(lines).encode("ascii"))
    return paths


def _filter(paths, calibrated, runtime):
    text = lambda T: ",".join(f"{v:.6f}" for v in frame_numbers(T[None])[0])  # noqa: E731
    return rc.filter_program(paths, calibrated, NOMINAL, tools={"1": text(TOOL)}, frames={"1": text(BASE)},
                             runtime_correction=runtime)


def _inverse(machine, pos, start):
    """The controller's INVERSE: nominal closed-form IK of the TCP pose in $BASE with $TOOL, the
    solution with the position's Status and Turn (nearest ``start`` among equals)."""
    g = machine.globals
    F = np.linalg.inv(to_matrix(g["$ROBROOT"])) @ to_matrix(g["$BASE"]) @ to_matrix(pos) \
        @ np.linalg.inv(to_matrix(g["$TOOL"]))
    F[:3, 3] *= 1e-3
    cands = solve_all(NOMINAL, F[None], extra_turns=True)[0]
    ok = np.isfinite(cands).all(axis=1)
    if not ok.any():
        return None, 1  # out of reach
    have = SCHEME.encode(NOMINAL, np.where(ok[:, None], cands, 0.0))
    score = np.where(ok, SCHEME.score(have, np.array([pos.values["S"], pos.values["T"]])), np.iinfo(int).max)
    start = np.deg2rad([start.values[f"A{k}"] for k in range(1, 7)])
    best = np.lexsort((np.abs(cands - start).sum(axis=1), score))[0]
    return (np.rad2deg(cands[best]), 0) if score[best] == 0 else (None, 2)


def _forward(machine, axis):
    q = np.deg2rad([[axis.values[f"A{k}"] for k in range(1, 7)]])
    T = np.linalg.inv(to_matrix(machine.globals["$BASE"])) @ to_matrix(machine.globals["$ROBROOT"])
    T[:3, 3] *= 1e-3
    pose = T @ NOMINAL.fk(q)[0] @ _metres(to_matrix(machine.globals["$TOOL"]))
    return _struct(pose, "E6POS", SCHEME.encode(NOMINAL, q)[0]), 0


def _metres(T):
    T = T.copy()
    T[:3, 3] *= 1e-3
    return T


def _struct(T: np.ndarray, kind: str = "FRAME", config=(0, 0)) -> Struct:
    s = Struct(kind, dict(zip(FIELDS["FRAME"], map(float, frame_numbers(T[None])[0]), strict=True)))
    if kind == "E6POS":
        s.values.update(S=int(config[0]), T=int(config[1]), **{f"E{k}": 0.0 for k in range(1, 7)})
    return s


def _machine(src: str, dat: str) -> Machine:
    m = Machine(_inverse, _forward)
    m.load_dat(dat)
    m.load_src(src)
    m.globals["$TOOL"], m.globals["$BASE"] = _struct(TOOL), _struct(BASE)
    return m


def _assert_chain_is(m: Machine, model, q: np.ndarray, tol_mm: float) -> None:
    """The routine's FK at joints ``q`` (rad, (6,)) built in the evaluator (RC_CONST(7), then
    RC_CONST(i):RC_JOINT(i) for each axis, then RC_CONST(8)) is ``model``'s FK: position within
    ``tol_mm`` mm, rotation within 1e-6."""
    m.globals["RC_TEST_Q"] = Struct("E6AXIS", {f"A{k + 1}": float(v) for k, v in enumerate(np.rad2deg(q))})
    m.globals["RC_TEST_Y"] = m.evaluate("RC_CONST(7)")
    for i in range(1, 7):
        m.globals["RC_TEST_I"] = i
        m.globals["RC_TEST_Y"] = m.evaluate(
            "RC_TEST_Y:RC_CONST(RC_TEST_I):RC_JOINT(RC_TEST_I, RC_TEST_Q)")
    Y = to_matrix(m.evaluate("RC_TEST_Y:RC_CONST(8)"))
    want = model.fk(q[None])[0]
    assert np.abs(Y[:3, 3] - want[:3, 3] * 1e3).max() < tol_mm
    assert np.abs(Y[:3, :3] - want[:3, :3]).max() < 1e-6


def _wrapped(src: str) -> list[tuple[str, str]]:
    """(the target as written, the call) of every RC_CORRECT / RC_CORRECTF call in the motions."""
    out = []
    for m in re.finditer(rf"{FUNCTION}F?\(", src.split(BEGIN)[0]):
        depth, k = 1, m.end()
        while depth:
            depth += {"(": 1, ")": -1}.get(src[k], 0)
            k += 1
        out.append((src[m.end():k - 1].split(",")[0], src[m.start():k]))
    return out


def _unwrapped(src: str) -> str:
    """The program part of a filtered .src with the calls taken out (the routine too)."""
    body = src[:src.index(BEGIN)].replace("RC_MEANT(1)", "XHOMEP")
    return re.sub(rf"{FRAME_FUNCTION}\((XP\d:OFFS|XHOMEP:OFFS), (?:XP\d|XHOMEP)\)", r"\1", body)


@pytest.fixture(scope="module")
def filtered(tmp_path_factory):
    folder = tmp_path_factory.mktemp("krl_runtime")
    truth, calibrated = _models()
    paths = _program(folder)
    return truth, calibrated, paths, _filter(paths, calibrated, True), _filter(paths, calibrated, False)


def test_routes_the_run_time_motions_and_leaves_every_other_byte(filtered):
    _, _, paths, rt, plain = filtered
    src, dat = (rt.outputs[p].decode("latin-1") for p in paths)
    assert _wrapped(src) == [(f"XP{i}:OFFS", f"{FRAME_FUNCTION}(XP{i}:OFFS, XP{i})") for i in (1, 2, 3)] + [
        ("RC_MEANT(1):OFFS", f"{FRAME_FUNCTION}(RC_MEANT(1):OFFS, RC_MEANT(1))")]  # XHOMEP as written
    assert rt.outputs[paths[1]] == plain.outputs[paths[1]]  # the .dat: as the offline filter writes it
    added = src[src.index(BEGIN):]
    assert added.rstrip().endswith(END) and src.count(BEGIN) == 1
    unwrapped = _unwrapped(src).rstrip("\n") + "\n"
    assert unwrapped == plain.outputs[paths[0]].decode("latin-1")
    records = {r.line: r for r in rt.motions}
    assert "corrected at run time" in records[8].reason and "corrected at run time" in records[9].reason
    assert "already in the corrected space" in " ".join(rt.warnings)  # LIN PSTORE (= $POS_ACT): not routed
    # XHOMEP:OFFS with XHOMEP corrected offline: routed with XHOMEP's value as the program wrote it
    assert "corrected at run time" in records[13].reason and "correct twice" not in " ".join(rt.warnings)
    assert "corrected at run time" not in records[12].reason


def test_the_krl_chain_is_the_calibrated_model(filtered):
    """The routine's FK (RC_CONST / RC_JOINT, run in the evaluator) against robocal's FK."""
    _, calibrated, paths, rt, _ = filtered
    m = _machine(rt.outputs[paths[0]].decode("latin-1"), rt.outputs[paths[1]].decode("latin-1"))
    model = controller_model(calibrated, NOMINAL)
    rng = np.random.default_rng(3)
    for q in np.deg2rad(rng.uniform(-120, 120, (5, 6))):
        _assert_chain_is(m, model, q, 2e-3)  # mm (32-bit REALs)


def test_executed_routine_lands_where_compensate_does(filtered):
    truth, calibrated, paths, rt, _ = filtered
    src, dat = (rt.outputs[p].decode("latin-1") for p in paths)
    m = _machine(src, dat)
    real = controller_model(truth, NOMINAL)
    model = controller_model(calibrated, NOMINAL)
    chain = calibrated_chain(calibrated, NOMINAL)
    zero = Struct("E6AXIS", {f"A{k}": 0.0 for k in range(1, 7)})
    rt_err, off_err, gap, calls, raw_err = [], [], [], [], []
    for offset in OFFSETS:
        m.globals["OFFS"] = Struct("FRAME", dict(zip(FIELDS["FRAME"], offset, strict=True)))
        for arg, call in _wrapped(src):
            before = dict(m.calls)
            target = m.evaluate(arg)  # what the program means, in $BASE with $TOOL (a FRAME)
            reference = m.evaluate(arg.split(":")[0])  # ... in the configuration of the POS it offsets
            target = Struct("E6POS", {**reference.values, **target.values})
            command = m.evaluate(call)
            calls.append(m.calls.get("INVERSE", 0) - before.get("INVERSE", 0))
            work = {k: m.calls.get(k, 0) - before.get(k, 0) for k in (":", "INV_POS", "statements")}
            assert command.type == "FRAME"  # as the motion's target was
            command = Struct("E6POS", {**reference.values, **command.values})
            X = _metres(to_matrix(m.globals["$BASE"]) @ to_matrix(target))  # meant TCP, robot base
            q_rt, err = _inverse(m, command, zero)
            assert err == 0
            landed = real.fk(np.deg2rad(q_rt)[None])[0] @ TOOL
            seed = np.deg2rad(_inverse(m, target, zero)[0])[None]
            raw_err.append(np.linalg.norm((real.fk(seed)[0] @ TOOL)[:3, 3] - X[:3, 3]) * 1e3)  # uncorrected
            off = compensate(model, NOMINAL, (X @ np.linalg.inv(TOOL))[None], seeds=seed)
            assert off.converged.all()
            off_landed = real.fk(off.joints)[0] @ TOOL
            rt_err.append(np.linalg.norm(landed[:3, 3] - X[:3, 3]) * 1e3)
            off_err.append(np.linalg.norm(off_landed[:3, 3] - X[:3, 3]) * 1e3)
            gap.append(np.linalg.norm((off.corrected_targets[0] @ TOOL)[:3, 3] - _metres(
                to_matrix(m.globals["$BASE"]) @ to_matrix(command))[:3, 3]) * 1e3)
            config = [target.values["S"], target.values["T"]]

            def solve(T, c=config):  # the controller's IK of world TCP poses (N, 4, 4) m -> rad
                return np.deg2rad(_inverse(m, _struct(np.linalg.inv(BASE) @ T[0], "E6POS", c), zero)[0])[None]

            ref, _ = reference_correction(chain, X[None], BASE[None], TOOL[None], solve)
            assert np.linalg.norm(ref[0][:3, 3] * 1e3 - to_matrix(command)[:3, 3]) < FLOAT32_MM
    rt_err, off_err = np.array(rt_err), np.array(off_err)
    assert (rt_err <= GOAL * off_err + FLOAT32_MM).all(), (rt_err, off_err)
    assert max(gap) < FLOAT32_MM
    assert max(calls) <= calibrated_chain(calibrated, NOMINAL).iterations
    print(f"uncorrected max {max(raw_err):.4f} mean {np.mean(raw_err):.4f}; run time / offline max "
          f"{(rt_err / off_err).max():.4f}; "
          f"landing error on the true robot, mm: run time max {rt_err.max():.4f} mean {rt_err.mean():.4f}; "
          f"offline compensate max {off_err.max():.4f} mean {off_err.mean():.4f}; command gap max "
          f"{max(gap):.5f} mm; INVERSE calls per motion {min(calls)}..{max(calls)}; last motion: {work}")


def test_crlf_program_keeps_its_line_ends(tmp_path):
    _, calibrated = _models()
    paths = _program(tmp_path, "\r\n")
    rt, plain = _filter(paths, calibrated, True), _filter(paths, calibrated, False)
    src = rt.outputs[paths[0]].decode("latin-1")
    assert "\n" not in src.replace("\r\n", "") and src.count(BEGIN) == 1
    assert _unwrapped(src).rstrip("\r\n") + "\r\n" == \
        plain.outputs[paths[0]].decode("latin-1")


def test_evaluator_frame_operator_against_matrices():
    """The evaluator's ':' and INV_POS are 4x4 products and inverses of Rz(A) Ry(B) Rx(C) frames."""
    m = Machine(_inverse, _forward)
    m.globals["F1"] = Struct("FRAME", dict(zip(FIELDS["FRAME"], (10.0, 20.0, 30.0, 90.0, 0.0, 0.0),
                                               strict=True)))
    out = m.evaluate("F1:{X 5.0, Y 0.0, Z 0.0, A 0.0, B 0.0, C 0.0}")
    assert np.allclose([out.values[k] for k in "XYZ"], [10.0, 25.0, 30.0], atol=1e-4)  # x turned onto y
    ident = m.evaluate("INV_POS(F1):F1")
    assert np.allclose([ident.values[k] for k in FIELDS["FRAME"]], 0.0, atol=1e-4)
    assert m.evaluate("ATAN2(1.0, 1.0)") == pytest.approx(45.0)
    assert m.evaluate("SIN(30.0)") == pytest.approx(0.5)


def test_cli_runtime_correction(tmp_path):
    from robocal.cli import main

    _, calibrated = _models()
    paths = _program(tmp_path)
    before = [p.read_bytes() for p in paths]
    calibrated.save(tmp_path / "cal.yaml")
    out = tmp_path / "out"
    out.mkdir()
    text = lambda T: ",".join(f"{v:.6f}" for v in frame_numbers(T[None])[0])  # noqa: E731
    assert main(["filter", *map(str, paths), "--calibrated", str(tmp_path / "cal.yaml"), "--nominal",
                 "kuka_kr16_2", "--tool", f"1={text(TOOL)}", "--frame", f"1={text(BASE)}",
                 "--runtime-correction", "-o", str(out)]) == 0
    src = (out / "rtprog.src").read_text()
    assert f"DEFFCT E6POS {FUNCTION}(RC_P:IN)" in src and src.count(BEGIN) == 1
    assert [p.read_bytes() for p in paths] == before  # the inputs are untouched


def test_a_frame_from_frames_is_not_routed_and_says_why(tmp_path):
    """F1:F2 with both FRAMEs has no Status/Turn to correct it in: named, not routed."""
    (tmp_path / "u.src").write_text("DEF u( )\n  $TOOL = TOOL_DATA[1]\n  $BASE = BASE_DATA[1]\n  LIN F1:F2\n"
                                    "  F2.X = 3.0\n  LIN F1:F2\nEND\n")
    (tmp_path / "u.dat").write_text("DEFDAT u\nDECL FRAME F1={X 900,Y 0,Z 900,A 0,B 90,C 0}\n"
                                    "DECL FRAME F2={X 0,Y 0,Z 0,A 0,B 0,C 0}\nENDDAT\n")
    _, calibrated = _models()
    res = rc.filter_program([tmp_path / "u.src", tmp_path / "u.dat"], calibrated, NOMINAL,
                            tools={"1": "0,0,100,0,0,0"}, frames={"1": "0,0,0,0,0,0"},
                            runtime_correction=True)
    assert FUNCTION not in res.outputs[tmp_path / "u.src"].decode()
    assert any("u.src:4: LIN: not corrected at run time: F1:F2 is a FRAME computed from no POS/E6POS" in w
               for w in res.warnings)
    assert all(r.status != "corrected" for r in res.motions)


def test_what_a_modified_position_starts_from_decides_its_routing(tmp_path):
    """XP2 = XP1 (corrected offline) then XP2.Z changed: correcting XP2 again would correct twice;
    P = $POS_ACT then changed: already in the corrected space; XP3 changed from its own value:
    routed."""
    (tmp_path / "v.src").write_text("DEF v( )\n  DECL E6POS P\n  $TOOL = TOOL_DATA[1]\n"
                                    "  $BASE = BASE_DATA[1]\n"
                                    "  PTP XP1\n  XP2 = XP1\n  XP2.Z = XP2.Z + 50.0\n  LIN XP2\n"
                                    "  XP3.Z = XP3.Z + 10.0\n  LIN XP3\n  P = $POS_ACT\n  P.X = P.X + 5.0\n"
                                    "  LIN P\nEND\n")
    P = np.linalg.inv(BASE) @ NOMINAL.fk(Q[:1]) @ TOOL
    (tmp_path / "v.dat").write_text("DEFDAT v\n" + "".join(f"DECL E6POS XP{i}={_e6pos(P[0], Q[0])}\n"
                                                            for i in (1, 2, 3)) + "ENDDAT\n")
    truth, calibrated = _models()
    text = lambda T: ",".join(f"{v:.6f}" for v in frame_numbers(T[None])[0])  # noqa: E731
    res = rc.filter_program([tmp_path / "v.src", tmp_path / "v.dat"], calibrated, NOMINAL,
                            tools={"1": text(TOOL)}, frames={"1": text(BASE)}, runtime_correction=True)
    src = res.outputs[tmp_path / "v.src"].decode()
    assert _wrapped(src) == [("XP3", f"{FUNCTION}(XP3)")]
    warned = " ".join(res.warnings)
    assert "v.src:8: LIN: not corrected at run time: its target is computed from a target corrected" in warned
    assert "v.src:13: LIN: not corrected at run time: its target is relative to the position" in warned
    # RC_CORRECT on the E6POS XP3 as the program leaves it at run time (Z + 10 mm)
    m = _machine(src, res.outputs[tmp_path / "v.dat"].decode())
    m.globals["XP3"].values["Z"] += 10.0
    target, command = m.evaluate("XP3"), m.evaluate(f"{FUNCTION}(XP3)")
    assert command.type == "E6POS" and all(command.values[k] == target.values[k] for k in ("S", "T", "E1"))
    zero = Struct("E6AXIS", {f"A{k}": 0.0 for k in range(1, 7)})
    X = _metres(to_matrix(m.globals["$BASE"]) @ to_matrix(target))
    real = controller_model(truth, NOMINAL)
    landed = real.fk(np.deg2rad(_inverse(m, command, zero)[0])[None])[0] @ TOOL
    off = compensate(controller_model(calibrated, NOMINAL), NOMINAL, (X @ np.linalg.inv(TOOL))[None],
                     seeds=np.deg2rad(_inverse(m, target, zero)[0])[None])
    off_landed = real.fk(off.joints)[0] @ TOOL
    rt_err, off_err = (np.linalg.norm(T[:3, 3] - X[:3, 3]) * 1e3 for T in (landed, off_landed))
    assert rt_err <= GOAL * off_err + FLOAT32_MM


@pytest.mark.parametrize("name", ["kuka_kr6_r700", "kuka_kr210_r2700"])
def test_chain_constants_of_other_arms_and_a_robot_base(name):
    """RC_CONST / RC_JOINT of another arm, calibrated with a robot base off the controller's and
    gear / cyclic / scale joint-error terms, run in the evaluator: robocal's FK of the calibrated
    model as the controller sees it."""
    from robocal.programs.dialects.krl.runtime import routine_text

    nominal = rc.Robot.from_catalog(name)
    rng = np.random.default_rng(7)
    names = [n for n in nominal.geometry_names if n[:-1] in ("a", "d", "alpha", "beta", "theta")]
    calibrated = nominal.with_values({n: nominal.get(n) + rng.normal(0, 1e-3) for n in names})
    terms = {"gear2_s1": 1e-4, "gear3_c2": -8e-5, "cyc4_3_s": 5e-5, "cyc6_5_c": 7e-5, "scale5": 2e-4}
    calibrated = calibrated.with_joint_errors(list(terms)).with_values(terms)
    robot_base = np.eye(4)
    robot_base[:3, :3] = _rot_z(0.3)
    robot_base[:3, 3] = [0.4, -0.2, 0.1]
    chain = calibrated_chain(calibrated, nominal, robot_base)
    m = Machine(_inverse, _forward)
    m.load_src(routine_text(chain, "test"))
    model = controller_model(calibrated, nominal, robot_base)
    for q in np.deg2rad(rng.uniform(-150, 150, (5, 6))):
        _assert_chain_is(m, model, q, 5e-3)  # mm (32-bit REALs, 3 m reach)


def _rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_robroot_off_the_world_gives_the_same_command_in_the_robots_frame(filtered):
    """$ROBROOT moved in the world and $BASE with it: the pose meant in the robot's base frame is
    the same, so is the command there (what INVERSE gets)."""
    _, _, paths, rt, _ = filtered
    src, dat = (rt.outputs[p].decode("latin-1") for p in paths)
    m = _machine(src, dat)
    m.globals["OFFS"] = Struct("FRAME", dict(zip(FIELDS["FRAME"], OFFSETS[0], strict=True)))
    arg, call = _wrapped(src)[0]
    before = to_matrix(m.evaluate(call))
    root = np.eye(4)
    root[:3, :3] = _rot_z(0.5)
    root[:3, 3] = [1.5, -0.7, 0.3]
    m.globals["$ROBROOT"] = _struct(root)
    m.globals["$BASE"] = _struct(root @ BASE)
    after = to_matrix(m.evaluate(call))
    assert np.abs(after[:3, 3] - before[:3, 3]).max() < 2e-3  # mm
    assert np.abs(after[:3, :3] - before[:3, :3]).max() < 1e-6


def test_a_failed_inverse_returns_the_target_unchanged(filtered):
    """Out of reach: INVERSE's status is not 0 on the first call, and RC_CORRECT returns P as given."""
    _, _, paths, rt, _ = filtered
    m = _machine(*(rt.outputs[p].decode("latin-1") for p in paths))
    far = Struct("E6POS", {**m.globals["XP1"].values, "X": 9000.0})
    out = m.call(FUNCTION, [far])
    assert out.values == far.values and m.calls["INVERSE"] == 1


def test_evaluator_forward_undoes_inverse(filtered):
    """The emulated controller: FORWARD(INVERSE(P)) is P, in $BASE with $TOOL, with its S and T."""
    _, _, paths, rt, _ = filtered
    m = _machine(*(rt.outputs[p].decode("latin-1") for p in paths))
    m.globals["RC_TEST_ERR"] = 0
    m.globals["RC_TEST_AX"] = Struct("E6AXIS", {f"A{k}": 0.0 for k in range(1, 7)})
    m.globals["RC_TEST_AX"] = m.evaluate("INVERSE(XP2, RC_TEST_AX, RC_TEST_ERR)")
    back = m.evaluate("FORWARD(RC_TEST_AX, RC_TEST_ERR)")
    want = m.globals["XP2"]
    assert m.globals["RC_TEST_ERR"] == 0
    assert np.abs(to_matrix(back) - to_matrix(want)).max() < 2e-3
    assert (back.values["S"], back.values["T"]) == (want.values["S"], want.values["T"])


def test_a_program_holding_the_routine_is_refused(filtered, tmp_path):
    """Filtering a filtered program again (--force) with the option would route twice: the routed
    motions are not routed again, and say so."""
    from robocal.core.errors import DataError

    _, calibrated, paths, rt, _ = filtered
    again = [tmp_path / p.name for p in paths]
    for p, q in zip(paths, again, strict=True):
        q.write_bytes(rt.outputs[p])
    text = lambda T: ",".join(f"{v:.6f}" for v in frame_numbers(T[None])[0])  # noqa: E731
    res = rc.filter_program(again, calibrated, NOMINAL, tools={"1": text(TOOL)}, frames={"1": text(BASE)},
                            runtime_correction=True, force=True)
    already = "not corrected at run time: it already goes through RC_CORRECT"
    assert sum(already in w for w in res.warnings) == 3
    assert res.outputs[again[0]].decode().count(BEGIN) == 1
    with pytest.raises(DataError, match="already holds"):  # a routine added to a file holding one
        KRLRuntime().routine(rt.outputs[paths[0]].decode("latin-1"), calibrated_chain(calibrated, NOMINAL),
                             [], "note")
