"""`filter --runtime-correction` for URScript: the generated RC_Correct is EXECUTED (tests/
urscript_subset_eval.py, get_inverse_kin by the nominal model's closed form, nearest qnear) on
the filtered program's run-time targets and compared with robocal's offline `compensate` on the
same targets and with where a 'true' robot lands; every other byte of the program unchanged."""

from __future__ import annotations

import re

import numpy as np
import pytest
from runtime_models import (
    MODEL_ERROR_FACTOR,
    ROUTINE_SLACK_MM,
    SAME_AS_OFFLINE_MM,
    calibrated_from,
    true_and_calibrated,
)
from urscript_subset_eval import Evaluator, NominalController, matrix  # noqa: I001 (tests/ on the path)

import robocal as rc
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.deploy.compensation import compensate, controller_model
from robocal.programs import filter_program
from robocal.programs.dialects.urscript.runtime import BEGIN, END, URScriptRuntime
from robocal.programs.runtime import calibrated_chain, reference_correction

NOMINAL = rc.Robot.from_catalog("ur10e")
TRUE, CALIBRATED = true_and_calibrated(NOMINAL)
WRITTEN_MM = 1e-5  # the routine's constants are written to 0.1 nm and 1e-10 rad
TCP = (0.0, 0.0, 0.12, 0.0, 0.0, 0.0)
START = np.array([0.2, -1.9, 1.6, -1.3, -1.57, 0.1])  # rad: the arm's joints before the motions

SCRIPT = "\n".join([
    "def cell():",
    "  set_tcp(p[0, 0, 0.12, 0, 0, 0])",
    "  home = p[0.5, -0.2, 0.4, 3.1, 0.1, 0]",
    "  movel(home, a=1.2, v=0.25)",
    "  i = 0",
    "  while i < 4:",
    "    dx = read_input_float_register(0)  # an offset known at run time",
    "    movel(pose_add(p[0.45, 0.1, 0.3, 3.14159, 0, 0], p[dx, 0, 0, 0, 0, 0]), a=1.2, v=0.25)",
    "    movel(p[0.4, dx, 0.35, 3.14159, 0, 0], a=1.2, v=0.25)",
    "    pick = pose_trans(p[0.5, 0.2, 0.3, 0, 3.14159, 0], p[0, 0, dx, 0, 0, 0])",
    "    movej(pick, a=1.2, v=0.25)",
    "    q = get_inverse_kin(p[0.4, dx, 0.35, 3.14159, 0, 0])",
    "    movej(q)",
    "    i = i + 1",
    "  end",
    "  here = get_actual_tcp_pose()",
    "  movel(pose_trans(here, p[0, 0, -0.05, 0, 0, 0]), a=1.2, v=0.25)",
    "  movel(pose_add(home, p[dx, 0, 0, 0, 0, 0]), a=1.2, v=0.25)",
    "end",
    ""])
EXPRESSIONS = ("pose_add(p[0.45, 0.1, 0.3, 3.14159, 0, 0], p[{d}, 0, 0, 0, 0, 0])",
               "p[0.4, {d}, 0.35, 3.14159, 0, 0]",
               "pose_trans(p[0.5, 0.2, 0.3, 0, 3.14159, 0], p[0, 0, {d}, 0, 0, 0])")


def _filter(tmp_path, text=SCRIPT, calibrated=CALIBRATED, **options):
    path = tmp_path / "cell.script"
    path.write_bytes(text.encode())
    res = filter_program(path, calibrated, NOMINAL, runtime_correction=True, **options)
    return res, next(iter(res.outputs.values())).decode()


@pytest.fixture(scope="module")
def filtered(tmp_path_factory):
    return _filter(tmp_path_factory.mktemp("ur"))


def _land(ctl, corrected, robot) -> np.ndarray:
    """Where ``robot``'s TCP lands (base frame, m) when the controller is given ``corrected``."""
    q = ctl.inverse_kin(corrected, ctl.joints)
    return controller_model(robot, NOMINAL).fk(q[None])[0] @ matrix(ctl.tcp)


def test_run_time_poses_are_routed_and_the_others_named(filtered):
    res, text = filtered
    assert "movel(RC_Correct(pose_add(p[0.45, 0.1, 0.3, 3.14159, 0, 0], p[dx, 0, 0, 0, 0, 0])), a=1.2" in text
    assert "movel(RC_Correct(p[0.4, dx, 0.35, 3.14159, 0, 0]), a=1.2" in text
    assert "movej(RC_Correct(pick), a=1.2" in text
    assert "movej(q)" in text  # a joint list: not a pose, never wrapped
    assert "movel(pose_trans(here," in text  # relative to where the robot is
    assert "movel(pose_add(home, p[dx" in text  # home is corrected offline: correcting again: twice
    reasons = " ".join(res.warnings)
    assert "already in the corrected space" in reasons and "would correct twice" in reasons
    routed = [m for m in res.motions if m.reason.startswith("corrected at run time")]
    assert [m.line for m in routed] == [8, 9, 11]
    # the block goes first in the program's def (defined before the motions use it)
    assert text.index(BEGIN) > text.index("def cell():") and text.index(END) < text.index("set_tcp")


def test_every_other_byte_unchanged(tmp_path, filtered):
    _, text = filtered
    path = tmp_path / "plain.script"
    path.write_text(SCRIPT)
    plain = next(iter(filter_program(path, CALIBRATED, NOMINAL).outputs.values())).decode()
    block = re.compile(r"  " + re.escape(BEGIN) + r"[\s\S]*?" + re.escape(END) + r"\n")
    assert len(block.findall(text)) == 1
    back = block.sub("", text)
    back = re.sub(r"RC_Correct\((pose_add\(p\[[^\]]*\], p\[[^\]]*\]\)|p\[[^\]]*\]|pick)\)", r"\1", back)
    assert back == plain


def _evaluator(text):
    ctl = NominalController(NOMINAL, TCP, START)
    return Evaluator(text, ctl), ctl


@pytest.mark.parametrize("form", EXPRESSIONS)
def test_routine_lands_on_the_true_robot_like_offline_compensation(filtered, form):
    _, text = filtered
    ev, ctl = _evaluator(text)
    Tt = matrix(ctl.tcp)
    errors = []
    for d in (-0.06, 0.0, 0.03, 0.09):
        target = ev.eval(form.format(d=d))
        X = matrix(target)
        before = ev.calls["get_inverse_kin"]
        corrected = ev.call("RC_Correct", target)
        assert 1 <= ev.calls["get_inverse_kin"] - before <= 3  # ITERATIONS
        # offline: robocal's compensate on the same target, seeded by the controller's joints
        q_nom = ctl.inverse_kin(target, ctl.joints)
        comp = compensate(controller_model(CALIBRATED, NOMINAL), NOMINAL, (X @ np.linalg.inv(Tt))[None],
                          seeds=q_nom[None])
        off = comp.corrected_targets[0] @ Tt
        rt = matrix(corrected)
        assert np.linalg.norm(rt[:3, 3] - off[:3, 3]) * 1e3 < SAME_AS_OFFLINE_MM
        landed = _land(ctl, corrected, TRUE)
        own = np.linalg.norm((_land(ctl, corrected, CALIBRATED) - landed)[:3, 3]) * 1e3
        error = np.linalg.norm(landed[:3, 3] - X[:3, 3]) * 1e3
        raw = np.linalg.norm(_land(ctl, target, TRUE)[:3, 3] - X[:3, 3]) * 1e3
        assert error <= MODEL_ERROR_FACTOR * own + ROUTINE_SLACK_MM
        assert error < raw / 5
        errors.append((raw, error, own))
    raw, err, own = np.array(errors).T
    assert raw.min() > 0.3 and err.max() < 0.2  # mm
    assert ev.log == []


def test_reference_correction_is_the_routine(filtered):
    _, text = filtered
    ev, ctl = _evaluator(text)
    target = ev.eval(EXPRESSIONS[0].format(d=0.05))
    rt = matrix(ev.call("RC_Correct", target))
    Tt = matrix(ctl.tcp)
    calls = []

    def solve(Tw):
        calls.append(1)
        from urscript_subset_eval import pose
        return ctl.inverse_kin(pose(Tw[0]), ctl.joints)[None]

    chain = calibrated_chain(CALIBRATED, NOMINAL)
    ref, n = reference_correction(chain, matrix(target)[None], np.eye(4)[None], Tt[None], solve)
    assert np.abs(ref[0][:3, 3] - rt[:3, 3]).max() * 1e3 < WRITTEN_MM and 1 <= n[0] <= 3


def test_routine_computes_the_gear_terms(tmp_path):
    """A calibrated model with gear / scale terms (the true robot has them too): the executed
    routine lands within 1.3x the model's own error; a compliance term is named as left out."""
    terms = {"gear2_s1": 1e-4, "gear3_c1": 1.5e-4, "scale5": 2e-4}
    true = TRUE.with_joint_errors(list(terms)).with_values(terms)
    cal = CALIBRATED.with_joint_errors(list(terms)).with_values(terms)
    res, text = _filter(tmp_path, calibrated=cal)
    assert "* sin(" in text and "left out" not in " ".join(res.warnings)
    ev, ctl = _evaluator(text)
    for d in (0.0, 0.08):
        target = ev.eval(EXPRESSIONS[1].format(d=d))
        corrected = ev.call("RC_Correct", target)
        landed = _land(ctl, corrected, true)
        own = np.linalg.norm((_land(ctl, corrected, cal) - landed)[:3, 3]) * 1e3
        assert np.linalg.norm(landed[:3, 3] - matrix(target)[:3, 3]) * 1e3 <= MODEL_ERROR_FACTOR * own + \
            ROUTINE_SLACK_MM
    res, text = _filter(tmp_path, calibrated=cal.with_joint_errors([*terms, "comp2_3"]))
    assert any("left out: the joint-error terms compliance" in w for w in res.warnings)
    assert "# not computed here (the calibrated model's joint-error terms): compliance" in text


def test_top_level_script_crlf_and_a_second_run(tmp_path):
    """Top-level statements: the block at the file's start (defined before use); CRLF kept; a
    filtered script given again: its routed motions are named, none routed twice."""
    body = "\r\n".join(SCRIPT.splitlines()[1:-1]).replace("\r\n  ", "\r\n")[2:] + "\r\n"
    res, text = _filter(tmp_path, body)
    assert text.startswith(BEGIN + "\r\n") and "\n" not in text.replace("\r\n", "")
    assert text.count("(RC_Correct(") == 3  # three motions routed
    out = tmp_path / "out.script"
    res.write(out)
    again = filter_program(out, CALIBRATED, NOMINAL, runtime_correction=True, force=True)
    assert next(iter(again.outputs.values())).decode().count(BEGIN) == 1  # nothing routed twice
    named = [m for m in again.motions if "already corrected at run time by robocal's RC_Correct" in m.reason]
    assert len(named) == 3
    with pytest.raises(DataError, match="already holds robocal's run-time correction"):
        URScriptRuntime().routine(text, calibrated_chain(CALIBRATED, NOMINAL), [], "")


def test_near_a_wrist_singularity_the_routine_says_it_did_not_converge(filtered):
    """Joint 5 at 0.02 deg: the fixed point does not converge in 3 steps (the controller's IK is
    ill-conditioned there): the routine returns its last iterate and says so (textmsg)."""
    _, text = filtered
    ev, ctl = _evaluator(text)
    q = np.array([0.3, -1.6, 1.4, -1.2, np.deg2rad(0.02), 0.4])
    ctl.joints = q
    from urscript_subset_eval import pose
    target = pose(NOMINAL.fk(q[None])[0] @ matrix(ctl.tcp))
    ev.call("RC_Correct", target)
    assert len(ev.log) == 1 and "no convergence" in ev.log[0]


def test_a_factory_calibrated_controller(tmp_path):
    """A UR controller's get_inverse_kin is its factory-calibrated model, not the datasheet: the
    routine (which never uses a nominal model) still lands within 1.3x the calibrated model's own
    error, written with the datasheet as --nominal; offline compensate with the datasheet as the
    controller's model misses by about the factory deltas (it needs the factory model)."""
    deltas = {"d1": 0.0008, "a3": -0.0006, "a4": 0.0004, "theta2": 0.001, "theta3": -0.0008, "d4": 0.0005,
              "theta5": 0.0006}
    factory = NOMINAL.with_values({k: NOMINAL.get(k) + v for k, v in deltas.items()})  # keeps the UR form
    true = perturbed(factory, 5, length_mm=(0.05, 0.2), angle_deg=(0.005, 0.02))
    cal = calibrated_from(true, 6)
    _, text = _filter(tmp_path, calibrated=cal)  # written with the datasheet nominal
    ctl = NominalController(factory, TCP, START)
    ev = Evaluator(text, ctl)
    Tt = matrix(ctl.tcp)
    for d in (-0.04, 0.06):
        target = ev.eval(EXPRESSIONS[0].format(d=d))
        X = matrix(target)
        corrected = ev.call("RC_Correct", target)
        landed = _land(ctl, corrected, true)
        own = np.linalg.norm((_land(ctl, corrected, cal) - landed)[:3, 3]) * 1e3
        error = np.linalg.norm(landed[:3, 3] - X[:3, 3]) * 1e3
        assert error <= MODEL_ERROR_FACTOR * own + ROUTINE_SLACK_MM
        for nominal, worse in ((NOMINAL, True), (factory, False)):
            q0 = ctl.inverse_kin(target, ctl.joints)
            comp = compensate(controller_model(cal, nominal), nominal, (X @ np.linalg.inv(Tt))[None],
                              seeds=q0[None])
            from urscript_subset_eval import pose
            off = _land(ctl, pose(comp.corrected_targets[0] @ Tt), true)
            miss = np.linalg.norm(off[:3, 3] - X[:3, 3]) * 1e3
            assert (miss > 0.5) if worse else (miss <= MODEL_ERROR_FACTOR * own + ROUTINE_SLACK_MM), miss


def test_a_polyscope_export(tmp_path):
    """The corpus's PolyScope-style palletizing program: ``place(k)``'s run-time ``target =
    pose_add(Place_base_p, p[d[0], ...])`` is routed (Place_base_p is no motion's target: not
    corrected offline), ``movel(get_actual_tcp_pose())`` is not; the block is defined in the
    program's def, where ``place`` (a nested def) sees it; each layer lands within 1.3x."""
    from pathlib import Path

    nominal = rc.Robot.from_catalog("ur5e")
    true, cal = true_and_calibrated(nominal)
    source = Path(__file__).parent / "data" / "programs" / "corpus" / "palletizing_ur5.script"
    res = filter_program(source, cal, nominal, runtime_correction=True, keep_unreached=True)
    text = next(iter(res.outputs.values())).decode()
    assert text.count("(RC_Correct(") == 1 and "    movel(RC_Correct(target), a=1.2, v=0.25)" in text
    assert text.index("def palletizing_ur5():") < text.index(BEGIN) < text.index("def place(k):")
    assert "movel(get_actual_tcp_pose(), a=0.5, v=0.1)" in text
    home = [0.1886, -1.6002, 1.6304, -1.7414, -1.6756, 0.3285]
    ctl = NominalController(nominal, (0, 0, 0.145, 0, 0, 0), home)
    ev = Evaluator(text, ctl)
    base = ev.eval("p[-0.39667, -0.27297, 0.36669, -2.0384, -2.3653, 0.2017]")  # Place_base_p as written
    for k in range(3):
        target = ev._builtin("pose_add", [base, ev.eval(f"p[0, 0, {k * 0.12}, 0, 0, 0]")], {})
        corrected = ev.call("RC_Correct", target)
        q = ctl.inverse_kin(corrected, ctl.joints)
        landed = controller_model(true, nominal).fk(q[None])[0] @ matrix(ctl.tcp)
        own = controller_model(cal, nominal).fk(q[None])[0] @ matrix(ctl.tcp)
        error = np.linalg.norm(landed[:3, 3] - matrix(target)[:3, 3]) * 1e3
        assert error <= MODEL_ERROR_FACTOR * np.linalg.norm((own - landed)[:3, 3]) * 1e3 + ROUTINE_SLACK_MM


def test_val3_refuses_and_names_the_languages_that_have_it():
    """VAL3 has no run-time correction (docs/programs.md says why): the option is refused, naming
    the languages that have one, URScript among them."""
    from pathlib import Path

    app = Path(__file__).parent / "data" / "programs" / "val3" / "pick_place"
    staubli = rc.Robot.from_catalog("staubli_tx2_140")
    with pytest.raises(DataError, match=r"writes routines in .*URScript, not .*VAL3"):
        filter_program(app, perturbed(staubli, 3), staubli, runtime_correction=True)
