"""Distance observations (ball bar / two SMR readings) on simulated truth."""

from __future__ import annotations

import numpy as np
from jacobian_check import central_difference

from robocal import Robot, calibrate
from robocal.data.measurements import Measurements
from robocal.data.registration import umeyama
from robocal.data.simulate import perturbed, sample_joints
from robocal.identify.problem import CalibrationProblem
from robocal.identify.space import ParameterSpace
from robocal.kinematics.transforms import make_transform


def ballbar(truth, n_pairs: int, noise_mm: float, seed: int) -> Measurements:
    """Pairs of random poses and the true distance between their tool points, plus noise."""
    rng = np.random.default_rng(seed)
    q = sample_joints(truth, 2 * n_pairs, rng)
    p = truth.fk(q)[:, :3, 3]
    d = np.linalg.norm(p[0::2] - p[1::2], axis=1) + rng.normal(0, noise_mm * 1e-3, n_pairs)
    return Measurements.from_arrays("distance", q, pair=np.repeat(np.arange(n_pairs), 2),
                                    distance=np.repeat(d, 2))


def _truth():
    nominal = Robot.from_catalog("abb_irb2600")
    nominal = nominal.with_frames(tool=make_transform(np.eye(3), [0.03, 0.02, 0.10]))
    truth = perturbed(nominal, np.random.default_rng(1))
    return nominal, truth


def test_jacobian_and_batch_match_the_residuals():
    nominal, truth = _truth()
    data = ballbar(truth, 12, 0.0, seed=2)
    problem = CalibrationProblem(nominal, data)
    state = problem.start(nominal)
    space = ParameterSpace(("a2", "theta3", "d4", "beta3", "tool.x"))
    J = problem.jacobian(state, space)
    h = 1e-7
    for k in range(space.size):
        fd = central_difference(problem, state, space, k, h)
        np.testing.assert_allclose(J[:, k], fd, atol=1e-7)
    X = np.random.default_rng(3).normal(0, 1e-4, (4, space.size))
    batch, _ = problem.profiled_residuals_batch(state.robot, space.robot, X)  # the population solvers' path
    for i in range(4):
        np.testing.assert_allclose(batch[i], problem.residuals(space.apply(state, X[i])), atol=1e-12)


def test_calibration_from_distances_recovers_the_shape():
    nominal, truth = _truth()
    cal, val = ballbar(truth, 150, 0.005, seed=4), ballbar(truth, 60, 0.0, seed=5)
    res = calibrate(nominal, cal, validation=val)
    assert not any(n.startswith("base.") for n in res.names)
    for name in ("alpha1", "a1", "theta1", "d1"):  # rigid motions of everything: invisible to distances
        assert res.identifiability.confounded_with[name] == []
    assert res.validation["rms"] < 0.25 * res.validation_before["rms"]
    # the tool-point cloud of the calibrated model matches the truth after a rigid fit
    q = sample_joints(truth, 200, np.random.default_rng(6))
    p, t = res.robot.fk(q)[:, :3, 3], truth.fk(q)[:, :3, 3]
    T = umeyama(p, t)
    fit = np.sqrt(np.mean(np.sum((p @ T[:3, :3].T + T[:3, 3] - t) ** 2, axis=1))) * 1e3
    p0 = nominal.fk(q)[:, :3, 3]
    T0 = umeyama(p0, t)
    fit0 = np.sqrt(np.mean(np.sum((p0 @ T0[:3, :3].T + T0[:3, 3] - t) ** 2, axis=1))) * 1e3
    assert fit < 0.2 * fit0


def test_robust_rejection_names_the_rows_of_the_bad_pair():
    nominal, truth = _truth()
    data = ballbar(truth, 150, 0.005, seed=7)
    distance = data.distance.copy()
    distance[200:202] += 0.003  # pair 100 (rows 200, 201) measured 3 mm long
    bad = Measurements.from_arrays("distance", data.joints, pair=data.pair, distance=distance)
    res = calibrate(nominal, bad, method="robust")
    rejected = res.to_dict()["rejected"]
    assert {r["source_row"] for r in rejected} >= {201, 202}  # 1-based lines of rows 200, 201
    weights = res.to_dict()["observations"]["weight"]
    assert len(weights) == len(bad) and weights[200] == weights[201] == 0.0
