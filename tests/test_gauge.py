"""Contact calibrations (plane, flush contacts, distances) predict their accuracy up to a rigid
motion of the world (and scale without a length reference): checked against the truth of
simulated campaigns, the gauge removal against a brute-force Procrustes fit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import least_squares

import robocal as rc
from robocal.data.simulate import simulate_tracker
from robocal.trust.coverage import Prediction, accuracy_line, prediction, workspace_sample
from robocal.trust.gauge import Gauge, gauge_free

ROBOT = rc.Robot.from_catalog("abb_irb2600")
HOLDS_ONLY_NEAR = "the calibration holds only near its poses"


def _fitted(points: np.ndarray, target: np.ndarray, scale: bool) -> np.ndarray:
    """``points (N, 3)`` moved by the rigid motion (and scale) that best fits ``target (N, 3)``."""
    ca, cb = points.mean(axis=0), target.mean(axis=0)
    A, B = points - ca, target - cb
    U, S, Vt = np.linalg.svd(B.T @ A)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    R = U @ D @ Vt
    s = float(np.sum(S * np.diag(D)) / np.sum(A**2)) if scale else 1.0
    return s * A @ R.T + cb


def _rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(e**2, axis=1)))) * 1e3


def true_error_mm(result, truth, scale: bool) -> float:
    """The calibrated model's TCP error (mm RMS over the workspace sample) against ``truth`` after
    the rigid motion (and scale) that best fits it, with the parameters the data cannot see (the
    kind's blind spot but the base frame and the scale's length) fitted too: what the data
    promise, measured without the prediction's algebra."""
    model = result.robot
    q = workspace_sample(model, 300, seed=7)
    blind = [n for obs in result.problem.observations for n in obs.not_observable(model)
             if not n.startswith("base.") and n != obs.scale_reference(model)]
    target = truth.fk(q)[:, :3, 3]

    def error(x):
        return (_fitted(model.with_values(dict(zip(blind, x, strict=True))).fk(q)[:, :3, 3], target, scale)
                - target).ravel()

    x = least_squares(error, model.values_of(blind)).x if blind else np.zeros(0)
    return _rms(error(x).reshape(-1, 3))


def test_gauge_removal_is_the_best_rigid_motion_and_scale():
    """A parameter error's predicted TCP error after the gauge is the RMS left by a Procrustes fit
    (rotation, translation, scale) of the displaced model's points to the model's."""
    q = workspace_sample(ROBOT, 400, seed=1)
    names = ["alpha1", "theta1", "a2", "theta2", "d4", "theta3", "a3", "alpha5", "d6"]
    delta = np.random.default_rng(2).normal(0, 1e-4, len(names))  # m, rad: linear regime
    moved = ROBOT.with_values(dict(zip(names, ROBOT.values_of(names) + delta, strict=True)))
    for scale in (None, "d4"):
        full, C = gauge_free(ROBOT, names, np.outer(delta, delta), Gauge(("plane",), scale), q)
        G = ROBOT.jacobian(q, full, kind="point")
        predicted = float(np.sqrt(np.einsum("nik,kl,nil->n", G, C, G).mean())) * 1e3
        p0 = ROBOT.fk(q)[:, :3, 3]
        brute = _rms(_fitted(moved.fk(q)[:, :3, 3], p0, scale is not None) - p0)
        assert predicted == pytest.approx(brute, rel=0.02)
    # the first link's errors are a rigid motion of the world: nothing is left of them
    first = ["alpha1", "theta1", "a1", "d1"]
    full, C = gauge_free(ROBOT, first, np.eye(4) * 1e-6, Gauge(("plane",), None), q)
    G = ROBOT.jacobian(q, full, kind="point")
    assert np.sqrt(np.einsum("nik,kl,nil->n", G, C, G).mean()) < 1e-9


@pytest.mark.parametrize("kind", ["plane", "flush", "distance"])
def test_clean_contact_campaign_predicts_its_accuracy_without_false_warning(kind):
    sim = simulate_tracker(ROBOT, 120, kind=kind, n_planes=3, seed=0, noise_mm=0.02,
                           smr_offsets=None if kind == "flush" else np.zeros((1, 3)))
    nominal = replace(ROBOT, tool=sim.truth.tool, nominal=None) if kind == "flush" else ROBOT
    result = rc.calibrate(nominal, sim.data)
    pa = result.predicted_accuracy
    assert not pa["holds_only_near_poses"] and not any(HOLDS_ONLY_NEAR in w for w in result.warnings)
    assert "up to a rigid motion of the world" in pa["gauge"]
    truth = true_error_mm(result, sim.truth, scale=kind != "distance")
    # the prediction includes the residual's noise; the truth leaves it out
    assert truth < pa["workspace"]["rms"] < 3 * pa["validated_mm"]
    line = accuracy_line(pa)
    assert line.startswith("predicted accuracy up to a rigid motion of the world")
    if kind == "distance":  # a scale bar is a length reference
        assert pa["scale"] is None and "scale" not in pa["gauge"]
    else:
        assert pa["scale"]["reference"] == "d4" and "the scale rests on d4's nominal" in line
        assert pa["scale"]["workspace_rms_mm"] > 1.0  # the prior's 2 mm on a 0.8 m link: not included
    again = Prediction.from_dict(result.to_dict()["predicted_accuracy"]["model"])
    assert again.gauge == pa["gauge"] and again.scale == pa["scale"]
    q = workspace_sample(result.robot, 20, seed=3)
    np.testing.assert_allclose(again.error_mm(result.robot, q), prediction(result).error_mm(result.robot, q))


def test_contacts_clustered_in_one_corner_still_warn():
    sim = simulate_tracker(ROBOT, 800, kind="plane", n_planes=3, seed=0, noise_mm=0.02,
                           smr_offsets=np.zeros((1, 3)))
    q = sim.data.joints[:, :3]
    distance = np.linalg.norm(q - np.median(q, axis=0), axis=1)
    near = sim.data.subset(distance <= np.quantile(distance, 0.15))  # 120 contacts in one region
    result = rc.calibrate(ROBOT, near)
    pa = result.predicted_accuracy
    assert pa["holds_only_near_poses"]
    assert any(w.startswith(HOLDS_ONLY_NEAR + ": predicted up to a rigid motion") for w in result.warnings)
    truth = true_error_mm(result, sim.truth, scale=True)
    assert truth > 3 * pa["validated_mm"]  # the warning is true
    assert pa["workspace"]["rms"] > 1.3 * pa["calibration_region"]["rms"]


def test_planes_with_a_scale_bar_are_up_to_a_rigid_motion_only():
    """A scale bar gives contacts their length: the prediction is up to a rigid motion, not scale,
    and the truth (rigid fit only) stays below it; tracker points give the world frame back."""
    planes = simulate_tracker(ROBOT, 120, kind="plane", n_planes=3, seed=0, noise_mm=0.02,
                              smr_offsets=np.zeros((1, 3)))
    bar = simulate_tracker(planes.truth, 40, kind="distance", seed=1, noise_mm=0.02, as_is=True)
    result = rc.calibrate(ROBOT, [planes.data, bar.data])
    pa = result.predicted_accuracy
    assert pa["gauge"] == "up to a rigid motion of the world (plane and distance data give no world frame)"
    assert pa["scale"] is None and not pa["holds_only_near_poses"]
    assert true_error_mm(result, planes.truth, scale=False) < pa["workspace"]["rms"]
    points = simulate_tracker(planes.truth, 30, seed=2, as_is=True)
    with_points = rc.calibrate(ROBOT, [planes.data, points.data])
    assert "gauge" not in with_points.predicted_accuracy
