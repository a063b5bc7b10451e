"""`filter --runtime-correction` for ABB RAPID: the generated routine is EXECUTED (tests/
rapid_subset_eval.py, CalcJointT by the nominal model's closed form in the robtarget's robconf) on
the filtered program's run-time targets and compared with robocal's offline `compensate` on the
same targets and with where a 'true' robot lands; every other byte of the program unchanged."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from rapid_subset_eval import Evaluator, NominalController  # noqa: I001 (tests/ on the path)
from runtime_models import MODEL_ERROR_FACTOR, ROUTINE_SLACK_MM, SAME_AS_OFFLINE_MM, true_and_calibrated

import robocal as rc
from robocal.core.errors import DataError
from robocal.deploy.compensation import compensate, controller_model
from robocal.programs import filter_program
from robocal.programs.dialects.rapid.runtime import BEGIN, END
from robocal.programs.runtime import calibrated_chain, reference_correction

NOMINAL = rc.Robot.from_catalog("abb_irb2600")
TRUE, CALIBRATED = true_and_calibrated(NOMINAL)
WRITTEN_MM = 1e-5  # the routine's constants are written to 1 nm and 1e-10 (quaternions)
NINE = "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]"

MODULE = "\n".join([
    "MODULE Cell",
    "  PERS tooldata tGrip := [TRUE,[[10,0,150],[0.9961947,0,0.0871557,0]],[2,[0,0,50],[1,0,0,0],0,0,0]];",
    '  PERS wobjdata wTable := [FALSE,TRUE,"",[[800,-200,300],[0.9659258,0,0,0.2588190]],'
    '[[0,0,0],[1,0,0,0]]];',
    f"  CONST robtarget pHome := [[1139.82,200.98,722.77],[0.1300295,-0.08641011,0.98767211,0.01137611],"
    f"[0,0,-1,0],{NINE}];",
    f"  CONST robtarget pBase := [[100,50,200],[0,0,1,0],[-1,0,-1,0],{NINE}];",
    f"  VAR robtarget pMod := [[150,0,250],[0,0,1,0],[-1,0,-1,0],{NINE}];",
    "  VAR robtarget pHere;",
    "  VAR robtarget pTmp;",
    "  VAR num dx := 0;",
    "  VAR num dy := 0;",
    "  PROC main()",
    "    MoveJ pHome, v1000, fine, tool0;",
    "    FOR i FROM 0 TO 3 DO",
    "      FOR j FROM 0 TO 2 DO",
    "        dx := i * 40;",
    "        dy := j * 30;",
    "        MoveL Offs(pBase, dx, dy, 0), v100, fine, tGrip\\WObj:=wTable;",
    "      ENDFOR",
    "    ENDFOR",
    "    MoveL RelTool(pBase, 0, 0, -20 \\Rz:=dx), v100, z10, tGrip\\WObj:=wTable;",
    "    pMod.trans.z := pMod.trans.z + dy;",
    "    MoveL pMod, v100, fine, tGrip\\WObj:=wTable;",
    "    MoveL Offs(pHome, dx, 0, 0), v100, fine, tool0;",
    "    pHere := CRobT(\\Tool:=tGrip \\WObj:=wTable);",
    "    MoveL Offs(pHere, 0, 0, 50), v100, z10, tGrip\\WObj:=wTable;",
    "    pTmp := pHome;",
    "    MoveL Offs(pTmp, dx, 0, 0), v100, fine, tool0;",
    "  ENDPROC",
    "ENDMODULE",
    ""])


@pytest.fixture(scope="module")
def filtered(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rt")
    path = folder / "cell.mod"
    path.write_text(MODULE)
    with_rt = filter_program(path, CALIBRATED, NOMINAL, runtime_correction=True)
    without = filter_program(path, CALIBRATED, NOMINAL)
    return path, with_rt, without


def _text(res) -> str:
    return next(iter(res.outputs.values())).decode("latin-1")


def _land(ev, ctl, target, tool, wobj, robot) -> np.ndarray:
    """Where ``robot``'s TCP lands (world, mm) when the controller is given ``target``."""
    q = ctl.calc_joint_t(ev, target, tool, wobj)
    P = controller_model(robot, NOMINAL).fk(q[None])[0]
    P[:3, 3] *= 1e3
    return P @ ev.matrix(tool["tframe"])


def test_chain_is_the_calibrated_model():
    chain = calibrated_chain(CALIBRATED, NOMINAL)
    q = np.random.default_rng(0).uniform(-2, 2, (50, 6))
    assert np.abs(chain.fk(q, np.eye(4)) - controller_model(CALIBRATED, NOMINAL).fk(q)).max() < 1e-12
    assert chain.left_out == ()
    # the joint-error terms of the joint's own angle are in the chain, the others are named
    terms = {"gear2_s1": 1e-4, "gear3_c2": -8e-5, "cyc4_3_s": 5e-5, "scale5": 2e-4}
    geared = CALIBRATED.with_joint_errors(list(terms)).with_values(terms)
    chain = calibrated_chain(geared, NOMINAL)
    assert chain.left_out == () and len(chain.harmonics) == 3
    assert np.abs(chain.fk(q, np.eye(4)) - controller_model(geared, NOMINAL).fk(q)).max() < 1e-12
    assert np.abs(chain.fk(q, np.eye(4)) - controller_model(CALIBRATED, NOMINAL).fk(q)).max() > 1e-5
    with_terms = CALIBRATED.with_joint_errors(["comp2_3", "gear2_s1"])
    assert calibrated_chain(with_terms, NOMINAL).left_out == ("compliance",)


def test_routine_computes_the_gear_terms(tmp_path):
    """A calibrated model with gear / cyclic terms (the true robot has them too): the executed
    routine lands within 1.3x the model's own error; a compliance term is named as left out."""
    terms = {"gear2_s1": 1e-4, "gear3_c1": 1.5e-4, "cyc6_3_c": 1e-4}
    true = TRUE.with_joint_errors(list(terms)).with_values(terms)
    cal = CALIBRATED.with_joint_errors(list(terms)).with_values(terms)
    path = tmp_path / "cell.mod"
    path.write_text(MODULE)
    res = filter_program(path, cal, NOMINAL, runtime_correction=True)
    assert "RC_HS{3}" in _text(res) and "left out" not in " ".join(res.warnings)
    ctl = NominalController(NOMINAL)
    ev = Evaluator(_text(res), ctl)
    tool, wobj = ev.globals["tgrip"], ev.globals["wtable"]
    W = ctl.world(ev, wobj)
    for expr in ("Offs(pBase, 0, 0, 0)", "Offs(pBase, 120, 60, -40)", "RelTool(pBase, 0, 0, -20 \\Rz:=90)"):
        X = W @ ev.matrix(ev.eval(expr))
        corrected = ev.eval(f"RC_Correct({expr}, tGrip, wTable)")
        landed = _land(ev, ctl, corrected, tool, wobj, true)
        own = np.linalg.norm((_land(ev, ctl, corrected, tool, wobj, cal) - landed)[:3, 3])
        assert np.linalg.norm(landed[:3, 3] - X[:3, 3]) <= MODEL_ERROR_FACTOR * own + ROUTINE_SLACK_MM
    compliant = cal.with_joint_errors([*terms, "comp2_3"])
    res = filter_program(path, compliant, NOMINAL, runtime_correction=True)
    assert any("left out: the joint-error terms compliance" in w for w in res.warnings)
    assert "! not computed here (the calibrated model's joint-error terms): compliance" in _text(res)


def test_only_run_time_targets_not_already_corrected_are_routed(filtered):
    _, res, without = filtered
    text = _text(res)
    assert text.count("RC_Correct(Offs(pBase, dx, dy, 0), tGrip, wTable)") == 1
    assert "RC_Correct(RelTool(pBase, 0, 0, -20 \\Rz:=dx), tGrip, wTable)" in text
    assert "MoveL RC_Correct(pMod, tGrip, wTable)" in text
    # pHome is corrected offline: the routine starts from its original value (RC_Meant), through a
    # variable it cannot: not routed (it would be corrected twice)
    assert "MoveL RC_Correct(Offs(RC_Meant(1), dx, 0, 0), tool0, wobj0)" in text
    assert "MoveL Offs(pTmp, dx, 0, 0)" in text
    assert "MoveL Offs(pHere, 0, 0, 50)" in text  # relative to where the robot is: not routed
    reasons = " ".join(res.warnings)
    assert "correcting it again would correct twice" in reasons
    assert "already in the corrected space" in reasons
    routed = [m for m in res.motions if m.reason.startswith("corrected at run time")]
    assert len(routed) == 4 and len(res.motions) == len(without.motions)
    assert "4 of them corrected at run time" in res.summary()
    assert [m.line for m in routed] == [17, 20, 22, 23]


def test_every_other_byte_unchanged(filtered):
    _, res, without = filtered
    text, plain = _text(res), _text(without)
    block = re.compile(re.escape(BEGIN) + r"[\s\S]*?" + re.escape(END) + r"\n")
    assert len(block.findall(text)) == 1
    back = block.sub("", text)
    back = re.sub(r"RC_Correct\(([\s\S]*?), (tGrip, wTable|tool0, wobj0)\)", r"\1", back)
    back = back.replace("RC_Meant(1)", "pHome")
    assert back == plain
    assert text.index(END) < text.rindex("ENDMODULE")


@pytest.mark.parametrize("single, displaced", [(False, False), (True, False), (False, True)])
def test_routine_lands_on_the_true_robot_like_offline_compensation(filtered, single, displaced):
    """``single``: the controller's float32 nums; ``displaced``: a program displacement active
    (PDispSet), which CalcJointT applies and the routine must take into the meant pose."""
    _, res, _ = filtered
    ctl = NominalController(NOMINAL)
    ev = Evaluator(_text(res), ctl, single=single)
    if displaced:
        ev.globals["c_progdisp"]["pdisp"] = ev.coerce("pose", [[30, -20, 15], [0.9990482, 0, 0, 0.0436194]])
    tool, wobj = ev.globals["tgrip"], ev.globals["wtable"]
    W = ctl.world(ev, wobj)
    Tt = ev.matrix(tool["tframe"])
    cases = [f"Offs(pBase, {dx}, {dy}, 0)" for dx in (0, 40, 80, 120) for dy in (0, 30, 60)]
    cases += [f"RelTool(pBase, 0, 0, -20 \\Rz:={a})" for a in (0, 40, 120)]
    errors = []
    for expr in cases:
        target = ev.eval(expr)
        before = dict(ev.calls)
        corrected = ev.eval(f"RC_Correct({expr}, tGrip, wTable)")
        calls = ev.calls["CalcJointT"] - before["CalcJointT"]
        assert 1 <= calls <= 3  # ITERATIONS
        assert corrected["robconf"] == target["robconf"] and corrected["extax"] == target["extax"]
        X = W @ ev.matrix(target)  # mm: the TCP pose the program means
        # offline: robocal's compensate on the same target, seeded by the controller's joints
        q_nom = ctl.calc_joint_t(ev, target, tool, wobj)
        F = X @ np.linalg.inv(Tt)
        F[:3, 3] *= 1e-3
        comp = compensate(controller_model(CALIBRATED, NOMINAL), NOMINAL, F[None], seeds=q_nom[None])
        off = comp.corrected_targets[0].copy()
        off[:3, 3] *= 1e3
        off = np.linalg.inv(W) @ off @ Tt
        rt = ev.matrix(corrected)
        assert np.linalg.norm(rt[:3, 3] - off[:3, 3]) < SAME_AS_OFFLINE_MM
        # on the true robot
        landed = _land(ev, ctl, corrected, tool, wobj, TRUE)
        model_error = np.linalg.norm((_land(ev, ctl, corrected, tool, wobj, CALIBRATED) - landed)[:3, 3])
        error = np.linalg.norm(landed[:3, 3] - X[:3, 3])
        raw = np.linalg.norm(_land(ev, ctl, target, tool, wobj, TRUE)[:3, 3] - X[:3, 3])
        assert error <= MODEL_ERROR_FACTOR * model_error + ROUTINE_SLACK_MM
        assert error < raw / 5
        errors.append((raw, error, model_error))
    raw, err, own = np.array(errors).T
    assert raw.min() > 0.3 and err.max() < 0.2  # mm: corrected from the true robot's error to the model's


def test_reference_correction_is_the_routine(filtered):
    """The numpy specification (programs/runtime.py) and the executed routine agree."""
    _, res, _ = filtered
    ctl = NominalController(NOMINAL)
    ev = Evaluator(_text(res), ctl)
    tool, wobj = ev.globals["tgrip"], ev.globals["wtable"]
    target = ev.eval("Offs(pBase, 80, 30, 0)")
    rt = ev.matrix(ev.eval("RC_Correct(Offs(pBase, 80, 30, 0), tGrip, wTable)"))
    W, Tt = _metres(ctl.world(ev, wobj)), _metres(ev.matrix(tool["tframe"]))
    X = W @ _metres(ev.matrix(target))

    def solve(Tw):
        local = np.linalg.inv(W) @ Tw[0]
        local[:3, 3] *= 1e3
        t = ev.coerce("robtarget", [list(local[:3, 3]), [1, 0, 0, 0], target["robconf"], target["extax"]])
        t["rot"] = ev.pose(local)["rot"]
        return ctl.calc_joint_t(ev, t, tool, wobj)[None]

    chain = calibrated_chain(CALIBRATED, NOMINAL)
    ref, calls = reference_correction(chain, X[None], W[None], Tt[None], solve)
    assert np.abs(ref[0][:3, 3] * 1e3 - rt[:3, 3]).max() < WRITTEN_MM and 1 <= calls[0] <= 3


def _metres(T):
    T = T.copy()
    T[:3, 3] *= 1e-3
    return T


def test_refused_where_no_routine_can_be_written(tmp_path):
    ls = tmp_path / "a.ls"
    ls.write_text("/PROG A\n/MN\n 1:L P[1] 100mm/sec FINE ;\n/POS\nP[1]{\n GP1:\n UF : 0, UT : 1, "
                  "CONFIG : 'N U T, 0, 0, 0',\n X = 1000.0 mm, Y = 0.0 mm, Z = 800.0 mm,\n W = 180.0 deg, "
                  "P = 0.0 deg, R = 0.0 deg\n};\n/END\n")
    with pytest.raises(DataError, match="--runtime-correction writes routines in"):
        filter_program(ls, CALIBRATED, NOMINAL, runtime_correction=True)
    mod = tmp_path / "m.mod"
    mod.write_text(MODULE)
    with pytest.raises(DataError, match="--tcp"):
        filter_program(mod, CALIBRATED, NOMINAL, runtime_correction=True, tcp={"tGrip": np.eye(4)})


def test_cli_runtime_correction(tmp_path):
    from robocal.cli import main

    mod = tmp_path / "m.mod"
    mod.write_text(MODULE)
    CALIBRATED.save(tmp_path / "cal.yaml")
    NOMINAL.save(tmp_path / "nom.yaml")
    out = tmp_path / "m_cal.mod"
    assert main(["filter", str(mod), "--calibrated", str(tmp_path / "cal.yaml"), "--nominal",
                 str(tmp_path / "nom.yaml"), "--runtime-correction", "-o", str(out), "--keep-unreached"]) == 0
    text = Path(out).read_text()
    assert "LOCAL FUNC robtarget RC_Correct" in text and text.count(BEGIN) == 1
    assert mod.read_text() == MODULE  # the input is untouched


def test_line_ends_and_a_second_run(tmp_path):
    """CRLF: the same motions routed, the block in the file's line ends; a filtered program given
    again (with --force) is refused: its motions would be corrected twice."""
    crlf = tmp_path / "crlf.mod"
    crlf.write_bytes(MODULE.replace("\n", "\r\n").encode())
    res = filter_program(crlf, CALIBRATED, NOMINAL, runtime_correction=True)
    text = _text(res)
    assert text.count("RC_Correct(") == 6 and "\r\n" + END + "\r\n" in text
    assert "\n" not in text.replace("\r\n", "")
    out = tmp_path / "out.mod"
    res.write(out)
    with pytest.raises(DataError, match="already holds robocal's run-time correction"):
        filter_program(out, CALIBRATED, NOMINAL, runtime_correction=True, force=True)


def test_offsets_from_a_target_corrected_offline_start_from_its_original_value(filtered):
    """``Offs(pHome, dx, 0, 0)`` where pHome is corrected offline: the routine is given pHome as the
    program wrote it (RC_Meant) and lands within 1.3x the model's own error, as if pHome had not
    been corrected."""
    path, res, _ = filtered
    ctl = NominalController(NOMINAL)
    ev = Evaluator(_text(res), ctl)
    original = Evaluator(path.read_text(), ctl)  # the program as written
    tool, wobj = ev.globals["tool0"], ev.globals["wobj0"]
    assert ev.matrix(ev.eval("pHome")) != pytest.approx(original.matrix(original.eval("pHome")))  # corrected
    for dx in (0.0, 60.0, -90.0):
        X = original.matrix(original.eval(f"Offs(pHome, {dx}, 0, 0)"))
        corrected = ev.eval(f"RC_Correct(Offs(RC_Meant(1), {dx}, 0, 0), tool0, wobj0)")
        landed = _land(ev, ctl, corrected, tool, wobj, TRUE)
        own = np.linalg.norm((_land(ev, ctl, corrected, tool, wobj, CALIBRATED) - landed)[:3, 3])
        assert np.linalg.norm(landed[:3, 3] - X[:3, 3]) <= MODEL_ERROR_FACTOR * own + ROUTINE_SLACK_MM


def test_near_a_wrist_singularity_the_routine_says_it_did_not_converge(tmp_path):
    """Axis 5 at 0.05 deg: the fixed point does not converge in 3 steps (the controller's IK is
    ill-conditioned there): the routine returns its last iterate and writes a warning to the
    event log (ErrWrite \\W); at 20 deg it converges silently."""
    from robocal.programs.dialects.rapid.configuration import ABBConfig
    from robocal.programs.rotations import matrix_to_quat

    lines = ["MODULE S"]
    for k, q5 in enumerate((0.05, 20.0)):
        q = np.deg2rad([[10, 20, 10, 30, q5, -20]])
        F = NOMINAL.fk(q)[0]
        quat = matrix_to_quat(F[None, :3, :3], np.array([[1.0, 0, 0, 0]]))[0]
        c = ABBConfig().encode(NOMINAL, q)[0]
        p = F[:3, 3] * 1e3
        lines.append(f"  CONST robtarget p{k} := [[{p[0]:.4f},{p[1]:.4f},{p[2]:.4f}],"
                     f"[{','.join(f'{v:.9f}' for v in quat)}],[{c[1]},{c[2]},{c[3]},{c[0]}],{NINE}];")
    lines += ["  VAR num dx := 0;", "  PROC main()", "    MoveL Offs(p0, dx, 0, 0), v100, fine, tool0;",
              "    MoveL Offs(p1, dx, 0, 0), v100, fine, tool0;", "  ENDPROC", "ENDMODULE", ""]
    path = tmp_path / "s.mod"
    path.write_text("\n".join(lines))
    res = filter_program(path, CALIBRATED, NOMINAL, runtime_correction=True)
    ev = Evaluator(_text(res), NominalController(NOMINAL))
    ev.eval("RC_Correct(Offs(p1, 0, 0, 0), tool0, wobj0)")
    assert ev.log == []
    ev.eval("RC_Correct(Offs(p0, 0, 0, 0), tool0, wobj0)")
    assert len(ev.log) == 1 and ev.log[0][1].get("w") and "no convergence" in ev.log[0][0][1]


def test_no_routing_when_an_external_axis_may_carry_the_arm(tmp_path):
    """Targets moving eax_a (a track?): the routine's chain is the arm alone, so nothing is routed
    (said); --fixed-base declares that no axis carries the arm: then the motions are routed. The
    judgement is the offline correction's (`carried_arm`): eax_a at two values over two targets may
    carry the arm; one target at one value would not (an axis held at one value moves no arm)."""
    text = MODULE.replace("[-1,0,-1,0],[9E+09,9E+09", "[-1,0,-1,0],[250,9E+09", 1)  # pBase at eax_a 250
    text = text.replace("[0,0,-1,0],[9E+09,9E+09", "[0,0,-1,0],[1250,9E+09", 1)  # pHome at eax_a 1250
    assert text.count("[250,9E+09") == 1 and text.count("[1250,9E+09") == 1
    path = tmp_path / "track.mod"
    path.write_text(text)
    res = filter_program(path, CALIBRATED, NOMINAL, runtime_correction=True, keep_unreached=True)
    assert "RC_Correct" not in _text(res)
    assert any("may carry the arm" in w and "--fixed-base" in w for w in res.warnings)
    res = filter_program(path, CALIBRATED, NOMINAL, runtime_correction=True, fixed_base=True)
    assert "RC_Correct(Offs(pBase, dx, dy, 0), tGrip, wTable)" in _text(res)
    text = MODULE.replace("[0,0,-1,0],[9E+09,9E+09", "[0,0,-1,0],[1234.567,9E+09", 1)  # pHome's eax_a
    path.write_text(text)
    res = filter_program(path, CALIBRATED, NOMINAL, runtime_correction=True, fixed_base=True)
    assert "RETURN [[1139.82,200.98,722.77],[0.1300295,-0.08641011,0.98767211,0.01137611],[0,0,-1,0]," \
           "[1234.567,9E+09,9E+09,9E+09,9E+09,9E+09]];" in _text(res)  # RC_Meant: pHome as written


def test_routing_and_offline_correction_judge_an_axis_held_still_alike(tmp_path):
    """One target at eax_a 250 (an axis held at one value, `carried_arm`: no carrier): the offline
    correction keeps it as an arm target, and the run-time correction now routes it too (its own
    any-non-zero rule refused it)."""
    text = MODULE.replace("[-1,0,-1,0],[9E+09,9E+09", "[-1,0,-1,0],[250,9E+09", 1)
    assert text != MODULE
    path = tmp_path / "held.mod"
    path.write_text(text)
    res = filter_program(path, CALIBRATED, NOMINAL, runtime_correction=True)
    assert "RC_Correct(Offs(pBase, dx, dy, 0), tGrip, wTable)" in _text(res)
    assert not any("may carry the arm" in w for w in res.warnings)
