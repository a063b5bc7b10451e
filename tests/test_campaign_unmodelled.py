"""Planning for the unmodelled error: the criterion against Monte Carlo, the search against brute
force, the scaling of the error, the planner and the CLI."""

from itertools import combinations

import numpy as np
import pytest

import robocal as rc
from robocal.campaign.information import candidate_information
from robocal.campaign.unmodelled import Candidates, Scans, Unmodelled, mean_square, search, unmodelled_error
from robocal.core.errors import RobocalError
from robocal.trust.posterior import Noise


def _toy(seed=0, C=10, r=3, p=4, m=2, R=40):
    """A synthetic problem: candidate blocks G (fitted) and N (unmodelled), region Jacobians."""
    rng = np.random.default_rng(seed)
    G, N = rng.normal(size=(C, r, p)), rng.normal(size=(C, r, m))
    Jf, Jn = rng.normal(size=(R, 3, p)), rng.normal(size=(R, 3, m))
    A = np.einsum("rik,ril->kl", Jf, Jf) / R
    A_cross = np.einsum("rik,ril->kl", Jf, Jn) / R
    variance = rng.uniform(0.2, 1.5, m)
    rms = np.sqrt(np.sum(np.diag(np.einsum("rik,ril->kl", Jn, Jn) / R) * variance))
    prior = np.r_[rng.uniform(0.5, 2.0, p - 1), 0.0]  # the last unknown has no prior (a frame)
    um = Unmodelled(rms_m=float(rms), terms=("compliance",), names=[f"c{i}" for i in range(m)],
                    N=N, variance=variance, A_cross=A_cross)
    return G, N, Jf, Jn, A, prior, um


def test_mean_square_is_the_monte_carlo_error_of_the_fitted_model():
    G, N, Jf, Jn, A, prior, um = _toy()
    design = [0, 2, 3, 5, 7]
    rng = np.random.default_rng(1)
    draws = 40000
    Gd, Nd = G[design].reshape(-1, G.shape[-1]), N[design].reshape(-1, N.shape[-1])
    theta = rng.normal(size=(draws, len(prior))) / np.sqrt(np.where(prior > 0, prior, 1.0))
    c = rng.normal(size=(draws, len(um.variance))) * np.sqrt(um.variance)
    y = theta @ Gd.T + c @ Nd.T + rng.normal(size=(draws, len(Gd)))
    M = Gd.T @ Gd + np.diag(prior)
    estimate = np.linalg.solve(M, Gd.T @ y.T).T  # the MAP estimate of the fitted unknowns
    error = np.einsum("rik,dk->dri", Jf, estimate - theta) - np.einsum("rim,dm->dri", Jn, c)
    monte_carlo = float(np.mean(np.sum(error**2, axis=2)))
    assert mean_square(G, A, prior, um, design) == pytest.approx(monte_carlo, rel=0.02)


def test_scan_is_the_direct_value_of_each_design():
    G, _, _, _, A, prior, um = _toy(seed=2, C=12)
    design = [1, 4, 6]
    H = G[design].reshape(-1, G.shape[-1])
    M = H.T @ H + np.diag(prior)
    X = np.einsum("crp,crm->pm", G[design], um.N[design])
    others = np.array([0, 2, 3, 5, 7, 8, 9, 10, 11])
    direct = [mean_square(G, A, prior, um, [*design, c]) for c in others]
    np.testing.assert_allclose(Scans(Candidates.of(G, A, um), M, X).values()[others], direct, rtol=1e-9)


def test_search_finds_the_brute_force_best_design():
    G, _, _, _, A, prior, um = _toy(seed=3, C=9)
    n = 3
    values = {d: mean_square(G, A, prior, um, d) for d in combinations(range(len(G)), n)}
    best = min(values, key=values.get)
    indices, value = search(G, A, prior, um, [0, 1, 2], None, np.random.default_rng(0), starts=4)
    assert value == pytest.approx(values[best], rel=1e-9)
    assert value == pytest.approx(mean_square(G, A, prior, um, indices), rel=1e-12)


def test_search_respects_conflicts():
    G, _, _, _, A, prior, um = _toy(seed=4, C=10)

    def conflicts(j: int) -> np.ndarray:  # neighbours in index order may not be chosen together
        out = np.zeros(len(G), np.int64)
        out[max(0, j - 1): j + 2] = 1
        return out

    indices, _ = search(G, A, prior, um, [0, 3, 6], conflicts, np.random.default_rng(0), starts=3)
    assert len(indices) == 3 and np.all(np.diff(indices) >= 2)


@pytest.fixture(scope="module")
def irb2600_plan():
    robot = rc.Robot.from_catalog("abb_irb2600")
    kw = dict(n_candidates=200, region_size=60, starts=1, smr=[[0.03, 0.0, 0.1]])
    return robot, kw, rc.plan_poses(robot, 20, **kw), rc.plan_poses(robot, 20, unmodelled_mm=0.3, **kw)


def test_the_terms_error_over_the_region_is_the_stated_one():
    """The joint-error terms' own TCP error over the region, by finite differences of the model
    with random term values drawn from the scaled priors, has the stated RMS."""
    from robocal.campaign.information import candidate_data
    from robocal.campaign.planner import _planning_robot

    robot = rc.Robot.from_catalog("abb_irb2600")
    rng = np.random.default_rng(0)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (100, 6))
    plan_robot = _planning_robot(robot, [[0.03, 0.0, 0.1]], None)[0]
    data = candidate_data(plan_robot, "point", q, np.ones((len(q), 1), bool))
    noise = Noise()
    info = candidate_information(plan_robot, data, noise)
    q_region = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (60, 6))
    um = unmodelled_error(plan_robot, data, noise, info, q_region, 0.25)
    full = plan_robot.with_joint_errors(um.names)
    base = full.fk(q_region)[:, :3, 3]
    draws = rng.normal(size=(400, len(um.names))) * np.sqrt(um.variance) * 1e-3  # small: linear
    square = [np.mean(np.sum((full.with_values(dict(zip(um.names, c, strict=True))).fk(q_region)[:, :3, 3]
                              - base) ** 2, axis=1)) for c in draws]  # a loop over the draws only
    assert np.sqrt(np.mean(square)) * 1e3 == pytest.approx(0.25e-3, rel=0.1)


def test_plan_with_an_unmodelled_error(irb2600_plan):
    _, _, plain, planned = irb2600_plan
    assert planned.settings["unmodelled_mm"] == 0.3
    assert planned.settings["unmodelled_terms"] == ["compliance", "backlash", "travel"]
    assert plain.settings["unmodelled_mm"] == 0.0
    # the prediction includes the error the fit cannot absorb: well above the noise-only one
    assert planned.predicted_rms_mm > plain.predicted_rms_mm + 0.1
    assert "unmodelled error 0.3 mm as compliance, backlash, travel" in planned.summary()
    assert "before the unmodelled error" in plain.summary()
    assert planned.to_dict()["settings"]["unmodelled_mm"] == 0.3


@pytest.mark.parametrize(("kw", "message"), [
    ({"unmodelled_mm": -0.1}, "finite RMS >= 0"),
    ({"unmodelled_mm": float("nan")}, "finite RMS >= 0"),
    ({"unmodelled_mm": 0.2, "criterion": "D"}, "I criterion"),
    ({"unmodelled_mm": 0.2, "unmodelled_terms": ["payload"]}, "no recorded conditions"),
    ({"unmodelled_mm": 0.2, "unmodelled_terms": ["wobble"]}, "unknown non-geometric term"),
    ({"unmodelled_mm": 0.2, "unmodelled_terms": ["thermal_groups"]}, "no recorded conditions"),
    ({"unmodelled_mm": 0.2, "unmodelled_terms": ["comp1_2"]}, "no effect here"),
])
def test_invalid_unmodelled_error(kw, message):
    robot = rc.Robot.from_catalog("abb_irb2600")
    with pytest.raises(RobocalError, match=message):
        rc.plan_poses(robot, 20, n_candidates=100, region_size=30, starts=1, **kw)


def test_cli_plans_for_the_unmodelled_error(tmp_path, capsys):
    from robocal.cli import main

    out = tmp_path / "poses.csv"
    code = main(["--quiet", "poses", "--robot", "abb_irb2600", "-n", "15", "-o", str(out),
                 "--candidates", "150", "--region-size", "40", "--starts", "1", "--smr-mm", "30,0,100",
                 "--unmodelled-mm", "0.2", "--unmodelled-terms", "compliance,gear"])
    assert code == 0 and out.exists()
    assert "unmodelled error 0.2 mm as compliance, gear" in capsys.readouterr().out


def test_measured_candidates_plan_for_the_error_their_measurements_show():
    """Candidates measured in an earlier campaign (a truth with known compliance): by default the
    region is the candidates and the unmodelled error is what their calibration with the
    unmodelled terms shows; its RMS over the candidates agrees with the true terms' own TCP error
    there (FK of the truth with and without them); named 0, the plan is for the noise alone."""
    from robocal.data.simulate import simulate_tracker

    robot = rc.Robot.from_catalog("abb_irb2600")
    names, values = ["comp2_3", "comp2_6", "comp3_6"], {"comp2_3": 4e-4, "comp2_6": -3e-4, "comp3_6": 5e-4}
    truth = robot.with_joint_errors(names).with_values(values)
    sim = simulate_tracker(truth, 120, noise_mm=0.02, seed=3)
    kw = dict(candidates=sim.data, region_size=500, starts=1)
    plan = rc.plan_poses(robot, 20, **kw)
    assert plan.settings["region"] == "the candidates"
    assert plan.settings["unmodelled_from"] == "the candidates' measurements"
    assert "the candidates' measurements show it" in plan.summary()
    q = sim.data.joints[np.unique(sim.data.pose_id, return_index=True)[1]]
    plain = sim.truth.with_joint_errors([])
    effect = sim.truth.fk(q)[:, :3, 3] - plain.fk(q)[:, :3, 3]
    true_mm = np.sqrt(np.mean(np.sum(effect**2, axis=1))) * 1e3
    assert plan.settings["unmodelled_mm"] == pytest.approx(true_mm, rel=0.2)
    noise_only = rc.plan_poses(robot, 20, unmodelled_mm=0.0, **kw)
    assert noise_only.settings["unmodelled_mm"] == 0.0 and noise_only.settings["unmodelled_from"] == \
        "none (noise only)"


def test_a_measurement_file_of_candidates_carries_its_measurements(tmp_path):
    """A candidate CSV with measured points (an earlier campaign) keeps them for the planner; a
    joints-only CSV has none."""
    from robocal.campaign import read_candidates
    from robocal.data.simulate import simulate_tracker

    robot = rc.Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(robot.with_joint_errors(["comp2_3"]).with_values({"comp2_3": 4e-4}), 60,
                           noise_mm=0.02, seed=2)
    sim.data.save(tmp_path / "earlier.csv")
    earlier = read_candidates(tmp_path / "earlier.csv", robot)
    np.testing.assert_allclose(earlier.measured.points, sim.data.points, atol=1e-9)
    plan = rc.plan_poses(robot, 15, candidates=earlier, region_size=100, starts=1)
    assert plan.settings["unmodelled_from"] == "the candidates' measurements"
    header = ",".join(f"q{i}_deg" for i in range(1, 7))
    (tmp_path / "joints.csv").write_text(header + "\n" + "\n".join(
        ",".join(f"{v:.4f}" for v in row) for row in np.rad2deg(sim.data.joints)) + "\n")
    assert read_candidates(tmp_path / "joints.csv", robot).measured is None
