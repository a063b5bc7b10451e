"""Planning for what the planner does not know (:mod:`robocal.campaign.hypotheses`): the criterion
averaged over the SMR's prior, and the predicted RMS of held-out measurements, against brute force,
the calibration's own prediction and simulated truth."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import robocal as rc
from robocal.campaign.exchange import (
    _Average,
    _Design,
    averaged_search,
    criterion_value,
    exchange_search,
    itself_only,
)
from robocal.campaign.hypotheses import SMR_BOX_MM, mean_criterion, smr_hypotheses
from robocal.data.simulate import simulate_tracker
from robocal.identify.priors import prior_sigma
from robocal.trust.coverage import Prediction, information_covariance

IRB = rc.Robot.from_catalog("abb_irb2600")


def _problems(seed: int, C: int = 10, K: int = 3):
    """K hypotheses of the same C candidates with different unknowns (p = 4, 5, 6 ...)."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(K):
        p = 4 + k
        G = rng.standard_normal((C, 2, p)) * rng.uniform(0.3, 2.0, (C, 1, 1))
        L = rng.standard_normal((p, p))
        out.append((G, L @ L.T / p, rng.uniform(0.0, 0.2, p)))
    return out


def test_the_quadrature_points_have_the_prior_box_mean_and_covariance():
    nominal = np.array([0.01, -0.02, 0.03])
    points = smr_hypotheses(nominal)
    np.testing.assert_allclose(points.mean(axis=0), nominal, atol=1e-15)
    d = points - nominal
    box = SMR_BOX_MM * 1e-3  # a uniform box of half-width h: variance h^2 / 3 per axis
    np.testing.assert_allclose(d.T @ d / len(d), np.eye(3) * box**2 / 3, atol=1e-15)
    uniform = np.random.default_rng(0).uniform(-box, box, (400_000, 3))  # the box itself, sampled
    np.testing.assert_allclose(uniform.T @ uniform / len(uniform), d.T @ d / len(d), atol=1e-5)  # 1 %


@pytest.mark.parametrize("criterion", ["I", "D"])
@pytest.mark.parametrize("seed", range(4))
def test_averaged_search_finds_the_brute_force_optimum_of_the_mean(criterion, seed):
    problems = _problems(seed)
    n = 4
    best = min(mean_criterion(problems, combo, criterion) for combo in itertools.combinations(range(10), n))
    found = averaged_search(problems, n, criterion=criterion, starts=4, seed=seed)
    assert found.value == pytest.approx(best, rel=1e-8)
    assert found.value == pytest.approx(mean_criterion(problems, found.indices, criterion), rel=1e-12)


@pytest.mark.parametrize("criterion", ["I", "D"])
def test_average_scans_equal_direct_computation(criterion):
    problems = _problems(7, C=14)
    design = _Average([_Design(G, A, criterion, itself_only(14), prior) for G, A, prior in problems])
    design.reset([0, 3, 5, 8])
    design.add(11)
    design.remove(3)
    added, removed = design.add_values(design.allowed()), design.remove_values()
    for j in range(14):
        if j not in design.members:
            expected = mean_criterion(problems, [*design.members, j], criterion)
            assert added[j] == pytest.approx(expected, rel=1e-7)  # the search's ridge
    for i, m in enumerate(design.members):
        rest = [x for x in design.members if x != m]
        assert removed[i] == pytest.approx(mean_criterion(problems, rest, criterion), rel=1e-7)
    assert design.value == pytest.approx(mean_criterion(problems, design.members, criterion), rel=1e-7)


def test_one_hypothesis_is_the_plain_search():
    (G, A, prior), = _problems(2, K=1)
    a = averaged_search([(G, A, prior)], 4, seed=1)
    b = exchange_search(G, A, 4, seed=1, prior=prior)
    np.testing.assert_array_equal(a.indices, b.indices)
    assert a.value == b.value == pytest.approx(criterion_value(G, A, a.indices, "I", prior))


def test_without_a_given_smr_the_prediction_is_the_mean_over_the_smr_prior():
    """The predicted accuracy of a plan made without an SMR is the calibration's own prediction
    (posterior of the chosen poses with the priors) averaged over the quadrature points."""
    region = np.random.default_rng(3).uniform(IRB.limits[:, 0], IRB.limits[:, 1], (300, 6))
    plan = rc.plan_poses(IRB, 16, n_candidates=300, region=region, starts=1)
    assert plan.settings["smr_prior_box_mm"] == SMR_BOX_MM
    squares = []
    for smr in smr_hypotheses(np.zeros(3)):
        at = rc.plan_poses(IRB, 16, smr=[smr], n_candidates=300, region=region, starts=1)  # its robot, names
        names = at.parameters
        J = at.robot.jacobian(plan.joints, names, kind="point").reshape(-1, len(names)) / 2e-5
        sigma = prior_sigma(at.robot, names)
        cov = information_covariance(J, np.where(np.isfinite(sigma), 1.0 / sigma, 0.0), 1.0)
        error = Prediction(tuple(names), cov, 0.0, 1.0, "test").error_mm(at.robot, region)
        squares.append(np.mean(error**2))
    assert plan.predicted_rms_mm == pytest.approx(np.sqrt(np.mean(squares)), rel=1e-3)
    given = rc.plan_poses(IRB, 16, smr=[[0.0, 0.0, 0.0]], n_candidates=300, region=region, starts=1)
    assert given.settings["smr_prior_box_mm"] == 0.0  # a given SMR: planned for that point


def test_the_heldout_prediction_adds_the_noise_model():
    plan = rc.plan_poses(IRB, 16, smr=[[0.02, -0.03, 0.08]], n_candidates=300, region_size=200, starts=1,
                         noise_mm=0.03)
    assert plan.settings["heldout_noise_mm"] == pytest.approx(np.sqrt(3) * 0.03, rel=1e-12)
    assert plan.predicted_heldout_mm == pytest.approx(np.hypot(plan.predicted_rms_mm, np.sqrt(3) * 0.03))
    assert "held-out check measurements" in plan.summary()
    assert plan.to_dict()["predicted_heldout_mm"] == plan.predicted_heldout_mm


@pytest.mark.slow
def test_heldout_prediction_matches_simulated_campaigns_with_unknown_smrs():
    """Plan with the defaults (SMR unknown), measure on perturbed arms whose SMR sits off the flange
    axis (as `robocal simulate` draws it), calibrate, check on held-out poses: the predicted model
    error and held-out RMS agree with what the calibrations reach (RMS over the robots)."""
    plan = rc.plan_poses(IRB, 16, n_candidates=1500, region_size=500, seed=1)
    rng = np.random.default_rng(0)
    q_eval = rng.uniform(IRB.limits[:, 0], IRB.limits[:, 1], (1000, 6))
    q_val = rng.uniform(IRB.limits[:, 0], IRB.limits[:, 1], (100, 6))
    model, held = [], []
    for seed in range(12):
        sim = simulate_tracker(IRB, joints=plan.joints, seed=seed)
        result = rc.calibrate(IRB, sim.data, validation=simulate_tracker(IRB, joints=q_val, seed=seed).data)
        e = result.robot.fk(q_eval)[:, :3, 3] - sim.truth.fk(q_eval)[:, :3, 3]
        model.append(np.mean(np.sum(e**2, axis=1)) * 1e6)
        held.append(result.validation["rms"] ** 2)
    assert np.sqrt(np.mean(model)) == pytest.approx(plan.predicted_rms_mm, rel=0.25)
    assert np.sqrt(np.mean(held)) == pytest.approx(plan.predicted_heldout_mm, rel=0.15)
    assert plan.predicted_heldout_mm > 1.3 * plan.predicted_rms_mm  # the noise is most of a check's RMS


@pytest.mark.slow
def test_measured_candidates_give_the_noise_their_calibration_shows():
    """Candidates measured with 0.05 mm noise while the plan states 0.02 mm: the held-out
    prediction takes the noise the measurements show, and matches the held-out RMS reached."""
    sim = simulate_tracker(IRB, 300, noise_mm=0.05, smr_offsets=[[0.02, -0.03, 0.08]], seed=4)
    cal = sim.data.subset(np.flatnonzero(sim.data.pose_id < 240))
    val = sim.data.subset(np.flatnonzero(sim.data.pose_id >= 240))
    plan = rc.plan_poses(IRB, 20, candidates=cal, smr=[[0.02, -0.03, 0.08]], seed=0)
    assert plan.settings["heldout_noise_from"] == "the residual of the candidates' calibration"
    assert plan.settings["heldout_noise_mm"] == pytest.approx(np.sqrt(3) * 0.05, rel=0.15)
    chosen = cal.subset(np.flatnonzero(np.isin(cal.pose_id, cal.pose_id[plan.candidate_index])))
    reached = rc.calibrate(IRB, chosen, validation=val).validation["rms"]
    assert reached == pytest.approx(plan.predicted_heldout_mm, rel=0.25)
