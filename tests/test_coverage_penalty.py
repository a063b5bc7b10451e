"""The coverage penalty of the workspace prediction (robocal.trust.coverage): the unmodelled error
grows beyond the joint ranges the calibration sampled. An arm with gear errors calibrated on poses
in the upper half of each joint's range (KUKA KR 16, truth known) is predicted near its true
workspace error; a full-range campaign's prediction is unchanged; the excursions against a loop."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.kinematics.joint_errors import candidate_names
from robocal.trust.coverage import SAMPLED_WIDTH_FLOOR, Prediction, workspace_sample

NOMINAL = rc.Robot.from_catalog("kuka_kr16_2")


def _gear_campaign(upper: bool, seed: int = 4):
    """80 poses (upper half of every joint's range, or all of it) of an arm with gear errors of
    0.15 mrad per harmonic (1 sigma), 0.01 mm noise; (data, truth)."""
    names = candidate_names(NOMINAL.n_joints, ["gear"])
    rng = np.random.default_rng(seed)
    truth = rc.simulate_tracker(NOMINAL, 10, noise_mm=0.01, seed=11).truth.with_joint_errors(names)
    truth = truth.with_values(dict(zip(names, rng.normal(0, 1.5e-4, len(names)), strict=True)))
    lo, hi = NOMINAL.limits[:, 0], NOMINAL.limits[:, 1]
    q = rng.uniform((lo + hi) / 2 if upper else lo, hi, (80, NOMINAL.n_joints))
    return rc.simulate_tracker(truth, joints=q, noise_mm=0.01, seed=12, as_is=True).data, truth


def _true_workspace_mm(result, truth) -> np.ndarray:
    q = workspace_sample(NOMINAL)
    return np.linalg.norm(result.robot.fk(q)[:, :3, 3] - truth.fk(q)[:, :3, 3], axis=1) * 1e3


def test_excursions_against_a_loop():
    sampled = np.column_stack([NOMINAL.limits[:, 0] / 2, NOMINAL.limits[:, 1] / 3])
    sampled[2] = [0.1, 0.1 + 1e-3]  # a joint barely moved: its width is the floor's
    p = Prediction(("a2",), np.eye(1), 0.1, 0.1, "test", sampled=sampled)
    q = workspace_sample(NOMINAL, 50, seed=3)
    x = p.outside(NOMINAL, q)
    for i in range(len(q)):
        for j in range(NOMINAL.n_joints):
            lo, hi = sampled[j]
            width = max(hi - lo, SAMPLED_WIDTH_FLOOR * (NOMINAL.limits[j, 1] - NOMINAL.limits[j, 0]))
            gone = lo - q[i, j] if q[i, j] < lo else q[i, j] - hi if q[i, j] > hi else 0.0
            assert x[i, j] == pytest.approx(gone / width, abs=1e-12)
    assert not Prediction(("a2",), np.eye(1), 0.1, 0.1, "test").outside(NOMINAL, q).any()


def test_upper_half_campaign_of_a_geared_arm_is_predicted_near_its_true_error():
    data, truth = _gear_campaign(upper=True)
    result = rc.calibrate(NOMINAL, data, nongeometric="none", progress=False)
    section = result.predicted_accuracy
    true = _true_workspace_mm(result, truth)
    true_rms = float(np.sqrt(np.mean(true**2)))
    grown, within = section["workspace"]["rms"], section["extrapolated"]["rms_within_mm"]
    assert within < 0.6 * true_rms < true_rms < 1.3 * grown  # without the growth: half the truth
    assert section["workspace"]["p95"] > 0.8 * np.percentile(true, 95)
    assert section["extrapolated"]["joints"] == [1, 2, 3, 4, 5, 6]
    assert "extrapolated beyond the joint ranges" in result.summary()
    assert [w for w in result.warnings if w.startswith("the workspace prediction is extrapolated")]
    # the prediction read back from the JSON grows the same way (compensate --result, filter)
    model = Prediction.from_dict(json.loads(result.to_json())["predicted_accuracy"]["model"])
    q = workspace_sample(NOMINAL)
    expected = np.sqrt(np.mean(model.error_mm(result.robot, q) ** 2))
    assert expected == pytest.approx(grown, rel=1e-9)
    old = Prediction.from_dict({**section["model"], "sampled_si": None})  # a JSON of an earlier version
    assert np.sqrt(np.mean(old.error_mm(result.robot, q) ** 2)) == pytest.approx(within, rel=1e-9)


def test_full_range_campaign_prediction_is_unchanged():
    data, truth = _gear_campaign(upper=False)
    result = rc.calibrate(NOMINAL, data, nongeometric="none", progress=False)
    section = result.predicted_accuracy
    plain = replace(Prediction.from_dict(section["model"]), sampled=None)
    q = workspace_sample(NOMINAL)
    within = float(np.sqrt(np.mean(plain.error_mm(result.robot, q) ** 2)))
    assert "extrapolated" not in section and section["workspace"]["rms"] == pytest.approx(within, rel=0.02)
    assert not any("holds only near" in w or "extrapolated" in w for w in result.warnings)


def test_malformed_sampled_ranges_are_refused():
    d = Prediction(("a2",), np.eye(1), 0.1, 0.1, "test", sampled=np.array([[0.0, 1.0]] * 6)).to_dict()
    assert Prediction.from_dict(d).sampled.shape == (6, 2)
    for bad in ([[1.0, 0.0]] * 6, [[0.0, float("nan")]] * 6, [[0.0, 1.0, 2.0]]):
        with pytest.raises(DataError, match="predicted_accuracy.model"):
            Prediction.from_dict({**d, "sampled_si": bad})
    three = Prediction.from_dict({**d, "sampled_si": [[0.0, 1.0]] * 3})
    with pytest.raises(DataError, match="sampled joint ranges are of 3 joints"):
        three.error_mm(NOMINAL, np.zeros((1, 6)))


def test_cli_names_the_extrapolated_joints(tmp_path, capsys):
    data, _ = _gear_campaign(upper=True, seed=5)
    data.save(tmp_path / "upper.csv")
    assert main(["calibrate", str(tmp_path / "upper.csv"), "--robot", "kuka_kr16_2", "--nongeometric", "none",
                 "--json", str(tmp_path / "r.json")]) == 0
    out = capsys.readouterr().out
    assert "extrapolated beyond the joint ranges the calibration sampled (q1 (covered" in out
    section = json.loads((tmp_path / "r.json").read_text())["predicted_accuracy"]
    assert section["workspace"]["rms"] > 1.5 * section["extrapolated"]["rms_within_mm"]
