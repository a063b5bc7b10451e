"""Plane-contact observations (seed 004): geometry, Jacobian, identifiability, calibration."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robocal import IdentificationError, Robot
from robocal.calibration.pipeline import calibrate
from robocal.data.measurements import Measurements
from robocal.data.registration import umeyama
from robocal.data.simulate import sample_joints, simulate_tracker
from robocal.identify.observations.plane import PlaneObservation, not_observable, scale_reference
from robocal.identify.problem import CalibrationProblem


def plane_campaign(n: int, n_planes: int, noise_mm: float, seed: int):
    """Contacts of a perturbed abb_irb2600 on random planes; each contact's true tip sits a
    N(0, noise_mm) probe error off its plane. Returns (sim, data, nominal): the nominal model
    carries the probe offset rounded to 1 mm (a drawing value), as the seed assumes it known."""
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(robot, n, kind="plane", n_planes=n_planes, seed=seed, noise_mm=noise_mm)
    data = sim.data
    nominal = replace(robot, tool=sim.truth.tool.round(3), nominal=None)
    return sim, data, nominal


def tracker_rms_mm(model, truth, q) -> float:
    """RMS tip position error (mm) at joints q after the best rigid fit (what a tracker sees)."""
    p, t = model.fk(q)[:, :3, 3], truth.fk(q)[:, :3, 3]
    T = umeyama(p, t)
    return float(np.sqrt(np.mean(np.sum((p @ T[:3, :3].T + T[:3, 3] - t) ** 2, axis=1))) * 1e3)


def heldout_rms_mm(result, data) -> float:
    """RMS distance (mm) of held-out contacts to the planes identified from the calibration set."""
    obs = PlaneObservation(data, result.robot)
    return float(np.sqrt(np.mean(obs.residuals(result.robot, result.state.nuisance) ** 2)) * 1e3)


def test_jacobian_matches_finite_differences():
    sim, data, nominal = plane_campaign(30, 3, 0.0, seed=2)
    problem = CalibrationProblem(nominal, data)
    state = problem.start(nominal)
    space = problem.space(nominal, ["alpha2", "a3", "theta4", "d4", "beta3", "tool.x", "tool.z"])
    J = problem.jacobian(state, space)
    eps = 1e-7
    for j in range(space.size):
        dx = np.zeros(space.size)
        dx[j] = eps
        fd = -(problem.residuals(space.apply(state, dx))
               - problem.residuals(space.apply(state, -dx))) / (2 * eps)
        assert np.allclose(J[:, j], fd, rtol=1e-6, atol=1e-9 * np.abs(J[:, j]).max())


@settings(max_examples=25, deadline=None)
@given(normal=st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 0.2),
       offset=st.floats(-2, 2), n_batch=st.integers(1, 4))
def test_plane_fit_recovers_any_plane(normal, offset, n_batch):
    """Points on a known plane (any normal, even horizontal ones): the fit's dependent axis is the
    normal's largest component and the distances are 0; shifted copies give the shift."""
    n = np.asarray(normal) / np.linalg.norm(normal)
    robot = Robot.from_catalog("abb_irb2600")
    rng = np.random.default_rng(0)
    q = sample_joints(robot, 12, rng)
    data = Measurements.from_arrays("plane", q, plane=np.zeros(12, int))
    obs = PlaneObservation(data, robot)
    pts = rng.uniform(-1, 1, (n_batch, 12, 3))
    pts -= (pts @ n - offset)[..., None] * n  # project onto n.p = offset
    obs.perm = np.array([[(np.argmax(np.abs(n)) + 1) % 3, (np.argmax(np.abs(n)) + 2) % 3,
                          np.argmax(np.abs(n))]])
    coef = obs.fit_planes(pts)
    assert np.abs(obs.signed_distance(pts, coef)).max() < 1e-9
    normal_fit = obs.plane_normals(coef[0])[0]
    assert abs(abs(normal_fit @ n) - 1) < 1e-9
    shifted = obs.signed_distance(pts + 1e-3 * n, coef) * np.sign(normal_fit @ n)
    assert np.allclose(shifted, 1e-3, atol=1e-12)


def test_profiled_cost_is_the_nuisance_cost_at_the_fitted_planes():
    _, data, nominal = plane_campaign(30, 2, 0.01, seed=4)
    obs = CalibrationProblem(nominal, data).observation
    names = ["a2", "d4", "tool.y"]
    X = np.random.default_rng(1).normal(0, 1e-4, (5, 3))
    r, coef = obs.profiled_residuals_batch(nominal, names, X)
    for p in (0, 4):
        robot = nominal.displaced(names, X[p])
        assert np.allclose(r[p], obs.residuals(robot, coef[p]), atol=1e-13)
        assert np.allclose(coef[p], obs.nuisance_start(robot), atol=1e-12)
    assert np.allclose(obs.residuals_batch(nominal, names, X, coef[2])[2], r[2], atol=1e-13)


def test_lsq_on_three_planes_reaches_the_probe_noise():
    sim, data, nominal = plane_campaign(90, 3, 0.01, seed=1)
    cal, val = data.subset(np.arange(60)), data.subset(np.arange(60, 90))
    res = calibrate(nominal, cal, method="lsq")
    assert res.solver.success
    assert heldout_rms_mm(res, val) < 1.2 * 0.01
    q = sample_joints(sim.truth, 100, np.random.default_rng(5))
    assert tracker_rms_mm(res.robot, sim.truth, q) < tracker_rms_mm(nominal, sim.truth, q) / 5
    assert [r["name"] for r in res.parameter_table() if r["name"].startswith("plane")][:3] == \
        ["plane0.a", "plane0.b", "plane0.c"]
    assert any(scale_reference(nominal) in w and "base.x" in w for w in res.warnings)


def test_one_plane_names_what_it_cannot_see():
    _, data, nominal = plane_campaign(60, 1, 0.01, seed=3)
    res = calibrate(nominal, data)
    ident = res.identifiability
    # the first link's rigid motions are absorbed by the plane or invisible in it
    assert {"alpha1", "a1", "theta1", "d1"} <= set(ident.dropped)
    assert any(c.startswith("plane0.") for n in ("a1", "d1") for c in ident.confounded_with[n])
    assert not set(not_observable(nominal)) & set(ident.names)
    table = {r["name"]: r for r in res.parameter_table()}
    assert all(table[n]["status"] == "dropped" and table[n]["sigma"] is None for n in ident.dropped)
    assert scale_reference(nominal) == "d4"


def test_bad_plane_data_gives_clear_errors():
    _, data, nominal = plane_campaign(20, 2, 0.0, seed=4)
    with pytest.raises(IdentificationError, match="plane contacts cannot determine"):
        calibrate(nominal, data)
    few = data.subset(np.flatnonzero(data.plane == 0)[:2].tolist() + np.flatnonzero(data.plane == 1).tolist())
    with pytest.raises(IdentificationError, match="at least 3"):
        CalibrationProblem(nominal, few)
    same = np.repeat(data.joints[:1], 5, axis=0)  # five contacts at one point: no plane
    line = Measurements.from_arrays("plane", same, plane=np.zeros(5, int))
    with pytest.raises(IdentificationError, match="line"):
        CalibrationProblem(nominal, line)
