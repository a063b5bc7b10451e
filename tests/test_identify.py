"""Identification on simulated truth: lsq, robust ridge + IGG3, identifiability, uncertainty."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from robocal import DataError, IdentificationError, PlausibilityError, Robot
from robocal.calibration.pipeline import calibrate
from robocal.data.measurements import Measurements
from robocal.data.registration import register
from robocal.data.simulate import simulate_tracker
from robocal.identify import robust
from robocal.identify.identifiability import analyze, condition_class
from robocal.identify.plausibility import check_corrections
from robocal.identify.problem import CalibrationProblem
from robocal.identify.robust import igg3_weights
from robocal.identify.solvers import get_solver

PI = np.pi


def irb2600() -> Robot:
    """The catalog's ABB IRB 2600 (J2 || J3)."""
    return Robot.from_catalog("abb_irb2600")


def campaign(n_cal=100, n_val=200, seed=0, **kw):
    """Calibration set, outlier-free validation set (same truth) and its noise floor (mm)."""
    sim = simulate_tracker(irb2600(), n_cal + n_val, seed=seed, **kw)
    clean = ~np.isin(np.arange(len(sim.data)), sim.outlier_rows)
    cal = sim.data.subset(np.flatnonzero(sim.data.pose_id < n_cal))
    is_val = (sim.data.pose_id >= n_cal) & clean
    val = sim.data.subset(np.flatnonzero(is_val))
    val_noise = sim.noise[is_val]
    floor = float(np.sqrt(np.mean(np.sum(val_noise**2, axis=1)))) * 1e3
    return sim, cal, val, floor


def test_noise_free_data_recover_the_truth():
    sim, cal, val, _ = campaign(60, 50, seed=3, noise_mm=0.0)
    res = calibrate(irb2600(), cal, validation=val)
    assert res.solver.success
    assert res.validation["rms"] < 1e-6  # mm
    assert res.validation_before["rms"] > 0.1


@pytest.mark.parametrize("seed", [1, 2])
def test_lsq_reaches_the_noise_floor(seed):
    _, cal, val, floor = campaign(seed=seed)
    res = calibrate(irb2600(), cal, validation=val)
    assert res.validation["rms"] < 1.10 * floor
    assert res.before["rms"] > 10 * res.after["rms"]


def test_identifiability_finds_the_textbook_redundancies():
    _, cal, _, _ = campaign(seed=4)
    res = calibrate(irb2600(), cal)
    # of d2 and d3 (parallel axes 2 and 3: one effect) the earlier is kept, whatever the rounding
    assert set(res.identifiability.dropped) == {"alpha1", "a1", "theta1", "d1", "d3", "theta6", "d6"}
    assert res.identifiability.confounded_with["d3"] == ["d2"]
    assert res.identifiability.confounded_with["d6"] == ["tool.z"]
    assert res.identifiability.rank == 27
    for key in ("O1", "O2", "O3", "O4"):
        assert res.identifiability.observability[key] > 0


def test_robust_rejects_gross_outliers():
    sim, cal, val, floor = campaign(seed=5, outliers=0.05)
    robust = calibrate(irb2600(), cal, method="robust", validation=val)
    assert robust.validation["rms"] < 1.2 * floor
    outlier_items = set(np.flatnonzero(np.isin(cal.source_row, sim.data.source_row[sim.outlier_rows])))
    assert outlier_items <= set(robust.rejected.tolist())
    assert len(robust.rejected) <= len(outlier_items) + 3


def test_least_squares_refits_without_its_gross_errors_and_says_so():
    sim, cal, val, floor = campaign(seed=5, outliers=0.05)
    lsq = calibrate(irb2600(), cal, validation=val)
    outlier_items = set(np.flatnonzero(np.isin(cal.source_row, sim.data.source_row[sim.outlier_rows])))
    assert outlier_items <= set(lsq.rejected.tolist())  # every simulated gross error, and ...
    assert len(lsq.rejected) <= len(outlier_items)  # ... only them
    assert lsq.validation["rms"] < 1.2 * floor
    assert any("rejected as gross errors" in w for w in lsq.warnings)
    # the same fit without the screen (plain Gauss-Newton) is pulled off by the outliers
    problem, space = lsq.problem, lsq.space
    plain = get_solver("lsq")(problem, lsq.initial, space)
    inliers = np.setdiff1d(np.arange(problem.n_items), sorted(outlier_items))
    def inlier_rms(state):  # noqa: E306
        return np.sqrt(np.mean(problem.position_errors(state)[inliers] ** 2))
    assert inlier_rms(plain.state) > 1.5 * inlier_rms(lsq.solver.state)


def test_least_squares_on_clean_data_is_plain_least_squares():
    _, cal, val, _ = campaign(seed=5)
    lsq = calibrate(irb2600(), cal, validation=val)
    assert lsq.solver.item_weights is None and not lsq.rejected.size
    assert not any("gross errors" in w for w in lsq.warnings)


def test_robust_builds_the_jacobian_once_per_state(monkeypatch):
    _, cal, _, _ = campaign(60, 1, seed=5, outliers=0.05)
    start = register(irb2600(), cal)
    problem = CalibrationProblem(start, cal)
    states = []
    original = CalibrationProblem.jacobian

    def counting(self, state, space):
        states.append(state.robot.values.tobytes() + state.nuisance.tobytes())
        return original(self, state, space)

    monkeypatch.setattr(CalibrationProblem, "jacobian", counting)
    out = robust.solve(problem, problem.start(start), problem.space(start), max_outer=4)
    assert out.nit == 4 and len(states) > 4
    assert len(states) == len(set(states))


@pytest.mark.parametrize("rule", ["gcv", "lcurve", "none"])
def test_robust_ridge_rules(rule):
    _, cal, val, floor = campaign(seed=6, outliers=0.05)
    res = calibrate(irb2600(), cal, method="robust", validation=val, ridge=rule)
    assert res.validation["rms"] < 1.3 * floor


def test_igg3_weight_function():
    w = igg3_weights(np.array([0.0, 1.5, 2.0, 3.0, 3.1, -2.0]), 1.5, 3.0)
    assert w[0] == 1 and w[1] == 1 and w[3] == 0 and w[4] == 0
    assert w[2] == pytest.approx((1.5 / 2.0) * ((3 - 2.0) / 1.5) ** 2)
    assert w[5] == w[2]
    with pytest.raises(IdentificationError):
        igg3_weights(np.zeros(2), 3.0, 1.5)


def test_several_smrs_and_pose_data():
    sim = simulate_tracker(irb2600(), 80, seed=7, n_smr=3)
    res = calibrate(irb2600(), sim.data)
    assert res.after["rms"] < 1.15 * sim.noise_floor_mm
    assert {"smr1.x", "smr2.z"} <= set(res.names)
    sim = simulate_tracker(irb2600(), 60, seed=8, kind="pose", rotation_noise_deg=0.001)
    res = calibrate(irb2600(), sim.data)
    assert res.after["rms"] < 1.2 * sim.noise_floor_mm
    assert "tool.rz" in res.names + res.identifiability.dropped


@pytest.mark.slow
def test_predicted_sigma_matches_monte_carlo_spread():
    """Repeat calibrate on fresh noise: the predicted 1-sigma match the observed spread.

    Link and tool parameters are compared directly; base.* are increments of a multiplicative
    chart about the tracker origin, whose absolute values are not component-wise comparable.
    """
    sim = simulate_tracker(irb2600(), 60, seed=9, noise_mm=0.0)
    truth, q = sim.truth, sim.data.joints
    exact = truth.fk(q)[:, :3, 3]
    rng = np.random.default_rng(10)
    estimates, predicted = [], []
    for _ in range(100):
        noisy = Measurements.from_arrays("point", q, points=exact + rng.normal(0, 2e-5, exact.shape))
        res = calibrate(irb2600(), noisy, nongeometric="none")  # the geometric model's posterior
        names = [n for n in res.names if not n.startswith("base.")]
        estimates.append(res.robot.values[res.robot.indices(names)])
        predicted.append(res.sigma[[res.unknowns.index(n) for n in names]])
    ratio = np.std(estimates, axis=0, ddof=1) / np.mean(predicted, axis=0)
    assert np.all(np.abs(ratio - 1) < 0.25), dict(zip(names, np.round(ratio, 3), strict=True))


def test_predicted_tcp_sigma_shape_and_scale():
    _, cal, val, floor = campaign(seed=11)
    res = calibrate(irb2600(), cal)
    s = res.predict_position_sigma(val.joints[:5])
    assert s.shape == (5, 3)
    assert np.all(s > 0) and np.all(s * 1e3 < floor)


def test_result_json_and_summary(tmp_path):
    _, cal, val, _ = campaign(seed=12, outliers=0.03)
    res = calibrate(irb2600(), cal, method="robust", validation=val)
    path = tmp_path / "r.json"
    res.save_json(path)
    d = json.loads(path.read_text())
    for key in ("before", "after", "validation_before"):
        assert set(d[key]) == {"n", "rms", "mean", "max", "p95"}
    assert set(d["validation"]) == {"n", "rms", "mean", "max", "p95", "noise_floor_mm"}
    assert d["identifiability"]["condition_class"] in ("weak", "moderate", "strong")
    names = [p["name"] for p in d["parameters"]]
    assert "a2" in names and d["parameters"][names.index("d3")]["status"] == "dropped"
    assert d["parameters"][names.index("d3")]["identification"] == "not identifiable"
    assert len(d["observations"]["measured"]) == len(cal)
    assert d["rejected"] and all(r["weight"] == 0 for r in d["rejected"])
    assert "->" in res.summary()


def test_condition_classes():
    assert condition_class(50) == "weak"
    assert condition_class(500) == "moderate"
    assert condition_class(5000) == "strong"


def test_bad_input():
    sim = simulate_tracker(irb2600(), 30, seed=13)
    with pytest.raises(IdentificationError, match="more poses"):
        calibrate(irb2600(), sim.data.subset(np.arange(8)))
    same = Measurements.from_arrays("point", np.repeat(sim.data.joints[:1], 40, axis=0),
                                    points=np.repeat(sim.data.points[:1], 40, axis=0))
    with pytest.raises(IdentificationError, match="degenerate"):
        calibrate(irb2600(), same)
    five = Robot.from_mdh(alpha=[0] * 5, a=[0.1] * 5, theta=[0] * 5, d=[0] * 5)
    with pytest.raises(DataError):
        calibrate(five, sim.data)
    with pytest.raises(IdentificationError, match="unknown method"):
        calibrate(irb2600(), sim.data, method="magic")


def test_check_corrections_limits_link_corrections_to_real_robots_errors():
    """Link lengths within max(5 mm, 1 % of the reach incl. the tool), angles within 5 deg."""
    tool = np.eye(4)
    tool[2, 3] = 0.2  # reach 2.29 m + 0.2 m: the limit is 24.9 mm
    big = irb2600().with_frames(tool=tool)
    small = Robot.from_catalog("meca500")  # reach 0.498 m: 1 % is below 5 mm
    names = ["a2", "theta3", "base.x"]

    def corrected(robot, **delta):
        return robot.displaced(list(delta), list(delta.values()))

    check_corrections(big, corrected(big, a2=0.0245, theta3=np.deg2rad(4.9)), names)
    check_corrections(small, corrected(small, a2=0.0049), names)
    check_corrections(big, big.displaced(["base.x"], [1.0]), names)  # frames are not judged
    for robot, delta, what in ((big, {"a2": 0.030}, "a2 by +30 mm"), (small, {"a2": -0.006}, "a2 by -6 mm"),
                               (big, {"theta3": np.deg2rad(6.0)}, "theta3 by +6 deg")):
        with pytest.raises(PlausibilityError, match=re.escape(what)):
            check_corrections(robot, corrected(robot, **delta), names)
    warnings = []
    check_corrections(big, corrected(big, a2=0.030), names, force=True, warnings=warnings)
    assert len(warnings) == 1 and warnings[0].startswith("FORCED") and "24.9 mm" in warnings[0]


def test_analyze_on_its_own_zero_column():
    J = np.random.default_rng(0).normal(size=(30, 3))
    J[:, 2] = 0
    ident = analyze(J, ["a1", "a2", "a3"], 10)
    assert ident.dropped == ["a3"] and ident.confounded_with["a3"] == []


@pytest.mark.slow
def test_real_meca500_and_irb120():
    """The real data sets: lsq beats the datasets README's plain baselines' nominal figures."""
    from robots import require_datasets

    from robocal.data.datasets import irb120, meca500

    root = require_datasets()
    cal, val = meca500(root)
    res = calibrate(Robot.from_catalog("meca500"), cal, validation=val)
    assert res.validation_before["rms"] == pytest.approx(0.182, abs=0.002)
    assert res.validation["rms"] < 0.044  # README: plain full-MDH fit 0.044 mm
    cal, val = irb120(root)
    res = calibrate(Robot.from_catalog("abb_irb120"), cal, validation=val)
    assert res.validation["rms"] < 0.625  # README: plain full-MDH fit 0.625 mm


def test_gram_route_equals_the_direct_svd():
    from robocal.identify.linalg import ScaledSVD

    rng = np.random.default_rng(3)
    J = rng.normal(size=(600, 20)) * np.logspace(-3, 1, 20)  # scaled columns: well conditioned
    r = rng.normal(size=600)
    gram = ScaledSVD.of(J)
    assert gram.U is None  # tall and well conditioned: the Gram route
    direct = np.linalg.pinv(J) @ r
    np.testing.assert_allclose(gram.solve(r), direct, rtol=1e-9)
    prior = rng.normal(size=20)
    ridge = np.linalg.solve(J.T @ J / np.outer(gram.scale, gram.scale) + 0.3 * np.eye(20),
                            (J / gram.scale).T @ r - 0.3 * prior * gram.scale) / gram.scale
    np.testing.assert_allclose(gram.solve(r, damping=0.3, prior=prior), ridge, rtol=1e-8)
    J[:, 1] = J[:, 0] / J[:, 0].std() * J[:, 1].std() + 1e-7 * rng.normal(size=600)  # near-collinear
    assert ScaledSVD.of(J).U is not None  # ill conditioned: the direct SVD


def test_an_infinite_condition_number_is_written_as_null():
    import json

    from robocal.identify.identifiability import Identifiability

    ident = Identifiability(names=["a2"], kept=[], dropped=[], confounded_with={}, rank=0,
                            condition_number=float("inf"), singular_values=np.zeros(0),
                            undetermined=["a2"])  # all held by their priors (was: ValueError in json)
    assert json.loads(json.dumps(ident.to_dict(), allow_nan=False))["condition_number"] is None


def test_the_misfit_check_judges_the_bulk_not_a_few_gross_errors():
    from robocal.identify.plausibility import bulk_rms_mm, check_residual
    rng = np.random.default_rng(0)
    points = rng.uniform(-0.5, 0.5, (100, 3))
    errors = rng.normal(0, 1e-3, (100, 3))  # 1.7 mm RMS: a robot's geometric errors
    errors[:5] += 0.2  # five gross errors of 350 mm
    assert np.sqrt(np.mean(np.sum(errors**2, axis=1))) * 1e3 > 50  # the plain RMS: another robot
    check_residual(bulk_rms_mm(errors), points, "data with five gross errors")  # the bulk: a robot
    with pytest.raises(PlausibilityError, match="misses the measurements"):  # wrong in every row
        check_residual(bulk_rms_mm(errors + 0.05), points, "another robot's data")
