"""Held-out figures judged against the calibration's prediction (robocal.trust.held_out): a
validation in a re-registered tracker frame split into the frame shift and the model's error, a
validation measured on another SMR nest not validated and named, clean validations (simulated, real)
consistent; the frame refit against a known rigid motion. Simulated on a KUKA KR 16 (known truth)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from robots import require_datasets

import robocal as rc
from robocal.cli import main
from robocal.data.datasets import meca500
from robocal.kinematics.transforms import make_transform, rotvec_to_matrix
from robocal.trust.held_out import (
    ANOTHER_SETUP,
    BEYOND,
    CONSISTENT,
    FRAME_SHIFT,
    HELD_OUT_FACTOR,
    HeldOutError,
    _frame_refit,
)

NOMINAL = rc.Robot.from_catalog("kuka_kr16_2")
# the next day's tracker frame: 0.5 mm and 4 mdeg off the calibration's, about the points' centre
TURN = rotvec_to_matrix(np.deg2rad(0.004) * np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8]))
SHIFT = np.array([0.3, -0.35, 0.2]) * 1e-3  # m
NEST_MM = np.array([25.0, -20.0, 25.0])  # another SMR nest on the tool, mm from the calibration's


@pytest.fixture(scope="module")
def campaign():
    """A simulated campaign (0.01 mm noise): 60 calibration poses, 20 held out, and the truth."""
    sim = rc.simulate_tracker(NOMINAL, 80, noise_mm=0.01, seed=5)
    first = sim.data.pose_id < 60
    return sim.data.subset(np.flatnonzero(first)), sim.data.subset(np.flatnonzero(~first)), sim.truth


def _moved(data):
    """``data`` seen from the re-registered tracker (the known rigid motion)."""
    c = data.points.mean(axis=0)
    return replace(data, points=(data.points - c) @ TURN.T + c + SHIFT)


def _other_nest(data, truth):
    """``data``'s poses measured on another SMR nest (noise 0.01 mm)."""
    moved = truth.with_values({f"tool.{k}": truth.get(f"tool.{k}") + v * 1e-3
                               for k, v in zip("xyz", NEST_MM, strict=True)})
    p = moved.fk(data.joints)[:, :3, 3]
    return replace(data, points=p + np.random.default_rng(1).normal(0, 1e-5, p.shape))


def _true_error_mm(result, data, truth) -> float:
    e = result.robot.fk(data.joints)[:, :3, 3] - truth.fk(data.joints)[:, :3, 3]
    return float(np.sqrt(np.mean(np.sum(e**2, axis=1)))) * 1e3


def test_frame_refit_recovers_a_known_rigid_motion():
    rng = np.random.default_rng(0)
    modelled = rng.uniform(-1, 1, (30, 3))
    T = make_transform(rotvec_to_matrix([0.01, -0.02, 0.005]), [1e-3, 2e-3, -1e-3])
    measured = modelled @ T[:3, :3].T + T[:3, 3]
    left, shift, turn = _frame_refit(measured - modelled, measured)
    assert np.abs(left).max() < 1e-12
    assert shift == pytest.approx(np.sqrt(np.mean(np.sum((measured - modelled) ** 2, axis=1))), rel=1e-9)
    assert turn == pytest.approx(np.linalg.norm([0.01, -0.02, 0.005]), rel=1e-9)


def test_clean_validation_is_consistent_and_validated_as_before(campaign):
    cal, val, truth = campaign
    result = rc.calibrate(NOMINAL, cal, validation=val, nongeometric="none", progress=False)
    held = result.held_out
    assert held.verdict == CONSISTENT and not any("held out" in w for w in result.warnings)
    assert result.predicted_accuracy["validated_mm"] == pytest.approx(result.validation["rms"])
    assert held.files[0].held_out_mm <= HELD_OUT_FACTOR * held.files[0].predicted_mm
    assert result.to_dict()["held_out"]["verdict"] == CONSISTENT


def test_next_day_frame_shift_is_split_from_the_model_error(campaign):
    cal, val, truth = campaign
    result = rc.calibrate(NOMINAL, cal, validation=_moved(val), nongeometric="none", progress=False)
    f = result.held_out.files[0]
    # the shift the motion makes at the validation points (the truth), and the model's true error
    c = val.points.mean(axis=0)
    applied = (val.points - c) @ TURN.T + c + SHIFT - val.points
    assert f.verdict == FRAME_SHIFT and result.held_out.verdict == FRAME_SHIFT
    assert f.frame_shift_mm == pytest.approx(np.sqrt(np.mean(np.sum(applied**2, axis=1))) * 1e3, rel=0.1)
    assert f.held_out_mm > 0.4 and f.model_error_mm < 0.05  # mm: 0.5 shift, 0.01 noise
    assert f.model_error_mm <= HELD_OUT_FACTOR * f.predicted_mm
    assert _true_error_mm(result, val, truth) < f.model_error_mm  # the noise is on top of it
    assert result.predicted_accuracy["validated_mm"] == pytest.approx(f.model_error_mm)
    assert "frame refitted" in result.predicted_accuracy["validated_from"]
    assert any("tracker-frame shift" in w and "re-registered" in w for w in result.warnings)
    assert "tracker-frame shift" in result.summary()


def test_another_smr_nest_is_not_validated_and_named(campaign):
    cal, val, truth = campaign
    result = rc.calibrate(NOMINAL, cal, validation=_other_nest(val, truth), nongeometric="none",
                          progress=False)
    f = result.held_out.files[0]
    assert f.verdict == BEYOND and f.held_out_mm > 30 and f.ratio > ANOTHER_SETUP
    assert result.predicted_accuracy["validated_from"].startswith("NOT validated")
    assert result.predicted_accuracy["validated_mm"] < 0.1  # the calibration residual, not 40 mm
    said = [w for w in result.warnings if w.startswith("NOT VALIDATED")]
    assert len(said) == 1 and "another SMR nest or tool" in said[0]
    assert result.to_dict()["held_out"]["files"][0]["cause"].startswith("with the SMR offset refitted")


def test_on_a_small_arm_another_nest_beyond_any_robot_error_is_refused_naming_the_nest():
    """A Denso VS-060-like OPW arm (approximate lengths): 40 mm is beyond what its geometric errors
    can leave, so the plausibility check refuses the file; the calibrated model names why."""
    limits = [[-170, 170], [-120, 120], [-125, 155], [-270, 270], [-120, 120], [-360, 360]]
    arm = rc.Robot.from_opw(0.0, 0.0, 0.0, 0.345, 0.305, 0.30, 0.07, offsets=[0] * 6, signs=[1] * 6,
                            degrees=True, length_unit="m", limits=limits, name="denso-like")
    sim = rc.simulate_tracker(arm, 80, noise_mm=0.01, seed=5)
    first = sim.data.pose_id < 60
    cal, val = sim.data.subset(np.flatnonzero(first)), sim.data.subset(np.flatnonzero(~first))
    with pytest.raises(HeldOutError, match="another SMR nest or tool") as info:
        rc.calibrate(arm, cal, validation=_other_nest(val, sim.truth), nongeometric="none", progress=False)
    assert "NOT VALIDATED" in str(info.value) and "tracker positions" not in str(info.value)
    moved = rc.calibrate(arm, cal, validation=_moved(val), nongeometric="none", progress=False)
    assert moved.held_out.verdict == FRAME_SHIFT and moved.held_out.model_error_mm < 0.03


def test_a_validation_of_another_robot_is_named_so(campaign):
    cal, val, truth = campaign
    other = rc.simulate_tracker(NOMINAL, 20, noise_mm=0.01, seed=40).truth  # the same model, another arm
    data = replace(val, points=other.fk(val.joints)[:, :3, 3])
    result = rc.calibrate(NOMINAL, cal, validation=data, nongeometric="none", progress=False, force=True)
    f = result.held_out.files[0]
    assert f.verdict == BEYOND and "another robot" in f.cause


def test_a_few_gross_errors_in_the_validation_are_no_other_setup(campaign):
    cal, val, truth = campaign
    points = val.points.copy()
    points[[3, 11]] += np.array([3e-3, -2e-3, 4e-3])  # two mistyped rows, 5 mm off
    result = rc.calibrate(NOMINAL, cal, validation=replace(val, points=points), nongeometric="none",
                          progress=False)
    f = result.held_out.files[0]
    assert f.held_out_mm > 1.0 and f.verdict == CONSISTENT  # mm: the RMS, the bulk within the prediction
    assert f.bulk_mm[0] <= HELD_OUT_FACTOR * f.predicted_mm


def test_cli_judges_the_validation_against_the_prediction(campaign, tmp_path, capsys):
    cal, val, truth = campaign
    cal.save(tmp_path / "cal.csv")
    _moved(val).save(tmp_path / "next_day.csv")
    _other_nest(val, truth).save(tmp_path / "nest.csv")
    args = ["calibrate", str(tmp_path / "cal.csv"), "--robot", "kuka_kr16_2", "--nongeometric", "none"]
    json_path = str(tmp_path / "r.json")
    assert main([*args, "--validate", str(tmp_path / "next_day.csv"), "--json", json_path]) == 0
    out = capsys.readouterr().out
    assert "held out against the prediction" in out and "frame shift" in out
    held = json.loads((tmp_path / "r.json").read_text())["held_out"]
    assert held["verdict"] == FRAME_SHIFT and held["files"][0]["frame_shift_mm"] > 0.4
    rc.calibration.result.load_result(tmp_path / "r.json")  # the schema takes it
    assert main([*args, "--validate", str(tmp_path / "nest.csv"), "-o", str(tmp_path / "m.yaml")]) == 0
    out = capsys.readouterr().out
    assert [ln for ln in out.splitlines() if ln.startswith("WARNING: NOT VALIDATED") and "another SMR" in ln]
    assert "beyond the prediction" in out and "(NOT validated: the held-out 40." in out


def test_real_validation_files_are_consistent_with_the_prediction():
    cal, val = meca500(require_datasets())
    result = rc.calibrate(rc.Robot.from_catalog("meca500"), cal, validation=val, nongeometric="none",
                          progress=False)
    assert result.held_out.verdict == CONSISTENT
    assert result.held_out.model_error_mm < 2 * result.held_out.predicted_mm
    assert not any("held out" in w for w in result.warnings)


def test_the_report_verdict_follows_the_held_out_judgement():
    """The report's verdict box (which reads the result JSON alone) takes the held-out judgement:
    beyond the prediction is 'do not use', whatever the noise floor says; after a frame shift the
    model's error with the frame refitted is judged against the floor, not the shifted RMS."""
    from robocal.report import verdict

    assert (verdict.HELD_OUT_FRAME_SHIFT, verdict.HELD_OUT_BEYOND) == (FRAME_SHIFT, BEYOND)
    base = {"converged": True, "validation": {"rms": 0.5, "n": 20, "noise_floor_mm": 0.03}}
    shifted = {**base, "held_out": {"verdict": FRAME_SHIFT, "model_error_mm": 0.035}}
    assert verdict.next_step(base)[0] == "care"  # 0.5 mm against a 0.03 mm floor
    assert verdict.next_step(shifted)[0] == "good"  # the 0.5 mm was the tracker's
    beyond = {**base, "validation": {"rms": 0.04, "n": 20, "noise_floor_mm": 0.03},
              "held_out": {"verdict": BEYOND, "model_error_mm": 0.04}}
    level, sentence = verdict.next_step(beyond)
    assert level == "bad" and sentence.startswith("NOT VALIDATED")


def test_evaluate_with_the_calibration_judges_as_calibrate_does(campaign, tmp_path):
    """`rc.evaluate` given the calibration's result (the object, or its JSON) judges a validation
    file the way `calibrate --validate` does (one code path: the same verdict and figures); without
    it, it says it cannot."""
    cal, val, truth = campaign
    moved = _moved(val)
    result = rc.calibrate(NOMINAL, cal, validation=moved, nongeometric="none", progress=False)
    result.save_json(tmp_path / "r.json")
    want = result.held_out.files[0]
    for given in (result, str(tmp_path / "r.json")):
        stats = rc.evaluate(result.robot, moved, result=given)
        got = stats["held_out"].files[0]
        assert got.verdict == want.verdict == FRAME_SHIFT
        for key in ("held_out_mm", "model_error_mm", "frame_shift_mm", "predicted_mm"):
            assert getattr(got, key) == pytest.approx(getattr(want, key), rel=1e-6), key
        assert any("tracker-frame shift" in w for w in stats.warnings)
        assert stats.to_dict()["held_out"]["verdict"] == FRAME_SHIFT
        assert "held out against the prediction" in stats.summary()
    plain = rc.evaluate(result.robot, moved)
    assert plain["held_out"] is None and "not judged against a calibration's prediction" in plain.summary()


def test_cli_evaluate_with_the_result_judges_the_file(campaign, tmp_path, capsys):
    cal, val, truth = campaign
    cal.save(tmp_path / "cal.csv")
    _other_nest(val, truth).save(tmp_path / "nest.csv")
    model, json_path = str(tmp_path / "m.yaml"), str(tmp_path / "r.json")
    assert main(["calibrate", str(tmp_path / "cal.csv"), "--robot", "kuka_kr16_2", "--nongeometric", "none",
                 "-o", model, "--json", json_path]) == 0
    capsys.readouterr()
    assert main(["evaluate", model, str(tmp_path / "nest.csv"), "--result", json_path]) == 0
    out = capsys.readouterr().out
    assert "beyond the prediction" in out and "WARNING: NOT VALIDATED" in out and "another SMR" in out


def test_a_calibration_worse_than_its_start_on_the_validation_data_is_said():
    """FIGAROH's tiago set, split 0: the validation RMS went 5.248 -> 7.388 mm with a prediction of
    4.10 mm ("consistent") and no warning; the start model is the yardstick not the answer's own."""
    from robocal.trust.held_out import worse_than_start

    said = worse_than_start({"rms": 5.248}, {"rms": 7.388})
    assert said.startswith("NOT BETTER") and "7.388 mm RMS, the start model by 5.248 mm" in said
    assert worse_than_start({"rms": 5.248}, {"rms": 0.617}) is None
    assert worse_than_start(None, {"rms": 1.0}) is None
