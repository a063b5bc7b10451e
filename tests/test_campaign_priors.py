"""Planning with the priors: the posterior information matrix J^T W J + P^-1 in the exchange
search (against direct inversion and brute force), the planner's predicted accuracy against the
calibration's own predicted-accuracy code, and what the data determine against what only the
priors do."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import robocal as rc
from robocal.campaign.exchange import RIDGE, _Design, criterion_value, exchange_search
from robocal.core.errors import DataError
from robocal.identify.priors import prior_sigma
from robocal.trust.coverage import Prediction, information_covariance

SMR = [[0.02, -0.03, 0.08]]


def _problem(seed: int, C: int = 10, r: int = 3, p: int = 6):
    rng = np.random.default_rng(seed)
    G = rng.standard_normal((C, r, p)) * rng.uniform(0.2, 2.0, (C, 1, 1))
    L = rng.standard_normal((p, p))
    prior = np.where(rng.random(p) < 0.5, rng.uniform(0.1, 5.0, p), 0.0)  # some without a prior
    return G, L @ L.T / p, prior


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.integers(1, 3), st.integers(3, 6))
def test_scans_with_a_prior_match_direct_posterior_inversion(seed, r, n):
    G, A, prior = _problem(seed, r=r)
    for criterion in ("I", "D"):
        design = _Design(G, A, criterion, lambda j: np.eye(1, len(G), j, dtype=np.int64)[0], prior)
        design.reset(list(range(n)))
        fast = design.add_values(design.allowed())
        for j in range(n, len(G)):
            H = G[list(range(n)) + [j]].reshape(-1, G.shape[-1])
            M = H.T @ H + np.diag(prior)
            ridged = M + RIDGE * np.eye(len(M))  # the search's ridge before the data determine M
            direct = (np.trace(np.linalg.solve(ridged, A)) if criterion == "I"
                      else -np.linalg.slogdet(ridged)[1])
            # the rank-one updates lose digits as the ridged matrix's condition number grows (a design
            # the ridge alone holds: values ~1/RIDGE): the tolerance scales with it
            rel = max(1e-6, 1e-14 * np.linalg.cond(ridged))
            assert fast[j] == pytest.approx(direct, rel=rel, abs=1e-9)
            if np.linalg.eigvalsh(M)[0] > 1e-6:  # the exact value (no ridge) where M is regular
                exact = np.trace(np.linalg.solve(M, A)) if criterion == "I" else -np.linalg.slogdet(M)[1]
                assert criterion_value(G, A, list(range(n)) + [j], criterion, prior) == \
                    pytest.approx(exact, rel=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_exchange_with_a_prior_finds_the_brute_force_optimum(seed):
    G, A, prior = _problem(seed, C=9, r=2)
    found = exchange_search(G, A, 3, criterion="I", starts=4, seed=seed, prior=prior)
    best = min(criterion_value(G, A, combo, "I", prior) for combo in itertools.combinations(range(9), 3))
    assert found.value == pytest.approx(best, rel=1e-9)


def test_a_prior_that_pins_a_direction_moves_the_design_elsewhere():
    # two directions, candidates that see one or the other: with a tight prior on the first,
    # the poses go to the second
    G = np.zeros((6, 1, 2))
    G[:3, 0, 0] = [1.0, 1.1, 1.2]
    G[3:, 0, 1] = [1.0, 1.1, 1.2]
    A = np.eye(2)
    free = exchange_search(G, A, 2, prior=np.array([0.0, 0.0])).indices
    assert sorted(free.tolist()) in ([1, 5], [2, 5], [2, 4])
    pinned = exchange_search(G, A, 2, prior=np.array([1e6, 0.0])).indices
    assert set(pinned.tolist()) <= {3, 4, 5}


def test_exchange_refuses_a_bad_prior():
    G, A, _ = _problem(0)
    with pytest.raises(DataError, match="prior precisions"):
        exchange_search(G, A, 3, prior=-np.ones(G.shape[-1]))


def test_predicted_accuracy_is_the_calibration_prediction_of_the_posterior():
    robot = rc.Robot.from_catalog("abb_irb2600")
    region = np.random.default_rng(3).uniform(robot.limits[:, 0], robot.limits[:, 1], (300, 6))
    plan = rc.plan_poses(robot, 16, smr=SMR, n_candidates=300, region=region, starts=1, noise_mm=0.02)
    names = plan.parameters
    J = plan.robot.jacobian(plan.joints, names, kind="point").reshape(-1, len(names)) / 2e-5  # whitened
    sigma = prior_sigma(plan.robot, names)
    cov = information_covariance(J, np.where(np.isfinite(sigma), 1.0 / sigma, 0.0), 1.0)
    expected = Prediction(tuple(names), cov, 0.0, 1.0, "test").error_mm(plan.robot, region)
    assert plan.predicted_rms_mm == pytest.approx(np.sqrt(np.mean(expected**2)), rel=1e-3)
    # the priors are information: the same poses without them predict worse
    data_only = Prediction(tuple(names), information_covariance(J, np.zeros(len(names)), 1.0), 0.0, 1.0,
                           "test").error_mm(plan.robot, region)
    assert "d1" in names and np.sqrt(np.mean(data_only**2)) > plan.predicted_rms_mm


def test_the_judgement_separates_estimated_not_determined_and_not_identifiable():
    robot = rc.Robot.from_catalog("abb_irb2600")
    q = np.random.default_rng(0).uniform(robot.limits[:, 0], robot.limits[:, 1], (40, 6))
    ident = rc.analyze(robot, q)  # the SMR on the flange axis: theta6 has no effect at all
    assert sorted(ident.kept + ident.undetermined + ident.dropped) == sorted(ident.names)
    # the first joint's beside the base frame, d3 beside d2 (parallel axes 2, 3), with the SMR on the
    # flange axis the wrist's alpha6, a6 beside d5, theta5 and d6 beside the tool: exactly confounded,
    # not identifiable whatever their prior; theta6 without effect
    assert ident.dropped == ["alpha1", "a1", "theta1", "d1", "d3", "alpha6", "a6", "theta6", "d6"]
    assert ident.confounded_with["d1"] == ["base.z"] and ident.confounded_with["d3"] == ["d2"]
    assert ident.confounded_with["theta6"] == []
    noisy = rc.analyze(robot, q, noise_mm=50.0)
    assert noisy.undetermined and all(0.5 < noisy.prior_ratio[nm] <= 1.0 + 1e-9 for nm in noisy.undetermined)
    # the noise weighs the data against the priors: very noisy data determine less
    assert len(noisy.undetermined) > len(ident.undetermined)
    assert set(noisy.kept) < set(ident.kept)
    with pytest.raises(DataError, match="noise"):
        rc.analyze(robot, q, noise_mm=0.0)


def test_plan_summary_says_what_is_not_identifiable_and_what_only_the_priors_hold():
    robot = rc.Robot.from_catalog("abb_irb2600")
    plan = rc.plan_poses(robot, 15, smr=SMR, n_candidates=200, region_size=50, starts=1)
    text = plan.summary()
    assert "not identifiable (exactly confounded" in text and "d1 (~base.z)" in text
    dropped = {d["name"]: d for d in plan.to_dict()["dropped"]}
    assert dropped["d1"]["status"] == "not identifiable"
    assert dropped["d1"]["reason"].startswith("not identifiable: confounded with base.z; held at nominal")
    assert dropped["d1"]["confounded_with"] == ["base.z"]
    assert set(plan.identifiability.undetermined) <= set(plan.parameters)


def test_a_model_with_joint_error_terms_is_planned_for_them_with_their_priors():
    from robocal.campaign.information import candidate_data, candidate_information
    from robocal.identify.priors import JOINT_ERROR_SIGMA
    from robocal.kinematics.joint_errors import candidate_names
    from robocal.trust.posterior import Noise

    robot = rc.Robot.from_catalog("abb_irb2600").with_joint_errors(candidate_names(6, ["compliance"]))
    plan = rc.plan_poses(robot, 30, smr=SMR, n_candidates=300, region_size=50, starts=1)
    terms = [nm for nm in plan.parameters if nm.startswith("comp")]
    assert terms and set(terms) <= set(robot.parameter_names)
    q = np.random.default_rng(1).uniform(robot.limits[:, 0], robot.limits[:, 1], (200, 6))
    data = candidate_data(plan.robot, "point", q, np.ones((200, 1), bool))
    info = candidate_information(plan.robot, data, Noise())
    j = info.names.index(terms[0])
    assert info.prior[j] == pytest.approx(1.0 / (JOINT_ERROR_SIGMA["compliance"] * info.scale[j]) ** 2)
