"""Joint-error terms travel and cyclic, the cyclic frequency search, and ``nongeometric="auto"``
(cross-validated model choice) on simulated robots with known injected errors."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from jacobian_check import central_difference, joint_error_jacobian

from robocal import Robot
from robocal.calibration.evaluation import model_errors
from robocal.calibration.model_selection import (
    SELECTION_TOLERANCE,
    WINSOR_QUANTILE,
    _candidates,
    _choose,
    _CrossValidation,
    _folds,
    _linearise,
    selection_table,
)
from robocal.calibration.pipeline import calibrate
from robocal.core.damped_least_squares import Status
from robocal.core.errors import IdentificationError, ModelError
from robocal.data.measurements import Measurements, approach_from_order, parse_csv, travel_from_order
from robocal.data.simulate import simulate_tracker
from robocal.identify.frequency_search import (
    ALIAS_CORRELATION,
    MAX_FREQUENCY,
    FrequencyScan,
    resolved_frequency,
    trig_sums,
)
from robocal.identify.lsq import gauss_newton
from robocal.identify.priors import prior_sigma
from robocal.identify.problem import CalibrationProblem
from robocal.identify.space import ParameterSpace
from robocal.kinematics.conditions import Conditions
from robocal.kinematics.joint_errors import JointErrorModel, candidate_names, cyclic_names

COMPLIANCE_GEAR_BACKLASH = (["comp2_3", "comp2_6", "comp3_6", "gear1_s1", "gear2_c1", "gear3_s2", "backlash1",
                             "backlash2", "backlash4"],
                            [4e-4, 3e-4, 5e-4, 2e-4, -1.5e-4, 1e-4, 2e-4, -1.5e-4, 3e-4])
TRAVEL_CYCLIC = (["travel1", "travel2", "travel3", *cyclic_names(1, 120), *cyclic_names(4, 80)],
                 [1e-3, -8e-4, 6e-4, 1.5e-4, -1e-4, 2e-4, 1e-4])


def _with_errors(robot, names, values):
    return replace(robot, joint_errors=JointErrorModel(tuple(names), np.array(values, float)))


def _panda_like() -> Robot:
    """A 7-joint MDH arm (Franka-Panda-like geometry), mm and deg."""
    return Robot.from_mdh(alpha=[0, -90, 90, 90, -90, 90, 90], a=[0, 0, 0, 82.5, -82.5, 0, 88],
                          theta=[0] * 7, d=[333, 0, 316, 0, 384, 0, 107], degrees=True, length_unit="mm",
                          name="panda_like", limits=[[-166, 166], [-101, 101], [-166, 166], [-176, -4],
                                                     [-166, 166], [-1, 215], [-166, 166]])


def test_travel_is_the_move_from_the_previous_pose_and_survives_subsets_and_files(rng):
    q = rng.uniform(-2, 2, (6, 3))
    pose_id = np.array([0, 0, 1, 2, 2, 3])
    travel = travel_from_order(q[[0, 0, 2, 3, 3, 5]], pose_id)
    data = Measurements.from_arrays("point", q[[0, 0, 2, 3, 3, 5]], points=rng.normal(size=(6, 3)),
                                    pose_id=pose_id, smr=[0, 1, 0, 0, 1, 0])
    qp = q[[0, 2, 3, 5]]
    expected = np.vstack([np.zeros(3), np.diff(qp, axis=0)])[[0, 0, 1, 2, 2, 3]]
    assert np.allclose(data.travel, expected) and np.allclose(travel, expected)
    assert np.array_equal(data.approach, approach_from_order(data.joints, pose_id))
    assert np.array_equal(np.sign(data.travel).astype(int), data.approach)
    part = data.subset(data.pose_id != 1)  # pose 2 keeps its move from pose 1 (now absent)
    assert np.allclose(part.travel, expected[data.pose_id != 1])
    back = parse_csv(part.to_csv())
    assert "travel1_rad" in part.to_csv() and np.array_equal(back.travel, part.travel)
    assert "travel1_rad" not in data.to_csv()  # implied by the row order: not written


@pytest.mark.parametrize("kind", ["point", "pose"])
def test_travel_and_cyclic_columns_match_finite_differences(kind):
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(robot, 12, kind=kind, noise_mm=0.0, seed=5)
    names = ["travel1", "travel3", *cyclic_names(2, 101.5), *cyclic_names(5, 7)]
    # pose rows differentiate the rotation-vector error exactly only at zero error
    nu = np.array([1e-3, -2e-3, 2e-4, -1e-4, 3e-4, 1e-4]) * (1.0 if kind == "point" else 1e-5)
    problem, state, space, J = joint_error_jacobian(sim.truth, sim.data, names, nu, ("a2", "d4"))
    h = 1e-7 if kind == "point" else 1e-6
    for c in range(2, space.size):
        fd = central_difference(problem, state, space, c, h)
        assert np.allclose(J[:, c], fd, rtol=1e-5, atol=1e-7)
    # the model the calibration returns applies the same offsets in fk
    model = JointErrorModel(tuple(names), nu)
    d = sim.data
    dq = model.offsets(sim.truth, d.joints, Conditions(d.approach, d.travel))
    assert np.allclose(dq[:, 0], nu[0] * d.travel[:, 0])
    q2 = d.joints[:, 1]
    assert np.allclose(dq[:, 1], nu[2] * np.sin(101.5 * q2) + nu[3] * np.cos(101.5 * q2))
    with pytest.raises(ModelError, match="frequency above"):
        cyclic_names(1, 2.0)
    with pytest.raises(ModelError, match="cyc"):
        JointErrorModel.from_dict({"parameters": {"cyc7_50_s": 1.0}}, 6)


def test_frequency_search_finds_the_injected_frequencies_and_nothing_in_noise():
    robot = Robot.from_catalog("abb_irb2600")
    for errors, expected in ((TRAVEL_CYCLIC, {(0, 120.0), (3, 80.0)}), (([], []), set())):
        sim = simulate_tracker(_with_errors(robot, *errors) if errors[0] else robot, 150,
                               noise_mm=0.02, seed=11)
        travel = [nm for nm in errors[0] if nm.startswith("travel")]
        base = calibrate(robot, sim.data, nongeometric=",".join(travel) or None)
        problem, state = base.problem, base.state
        n = robot.n_joints
        J = problem.jacobian(state, base.space)
        Jtheta = problem.jacobian(state, ParameterSpace([f"theta{i + 1}" for i in range(n)]))
        found = FrequencyScan(sim.data.joints, sim.data.pose_id).search(
            J, problem.residuals(state), Jtheta, problem.observation.rows_per_item)
        assert {(i, round(f)) for i, f in found} == expected
        for i, f in found:
            assert f == pytest.approx(120.0 if i == 0 else 80.0, abs=0.1)  # peak width ~0.5


def _brute_force_resolved(q: np.ndarray, step: float) -> float:
    """resolved_frequency's definition evaluated directly: the spectral window at every offset."""
    offsets = np.arange(int(np.ceil(2 * MAX_FREQUENCY / step)) + 1) * step
    window = np.abs(np.exp(1j * offsets[:, None] * q[None]).mean(axis=1))
    out = int(np.argmax(window < ALIAS_CORRELATION))
    alias = np.flatnonzero(window[out:] >= ALIAS_CORRELATION)
    return MAX_FREQUENCY if alias.size == 0 else min(offsets[out + alias[0]] / 2, MAX_FREQUENCY)


def test_cyclic_search_stops_where_a_grid_of_angles_aliases():
    rng = np.random.default_rng(3)
    # a positioner's turn table in 22.5 deg steps read with 0.05 deg of jitter, 13 tilts of 5 deg
    turn = np.tile(np.deg2rad(np.arange(16) * 22.5), 13) + np.deg2rad(0.05) * rng.standard_normal(208)
    tilt = np.repeat(np.deg2rad(np.arange(-30, 31, 5)), 16)
    q = np.column_stack([tilt, turn])
    scan = FrequencyScan(q, np.arange(208))
    for i, h in ((0, 5.0), (1, 22.5)):  # Nyquist of a grid of step h: pi / h = 180 / h cycles/rev
        assert scan.top[i] == pytest.approx(180.0 / h, abs=scan.step[i])
        assert scan.top[i] == pytest.approx(_brute_force_resolved(q[:, i], scan.step[i]), abs=1e-9)
        assert scan.grids[i].max() < scan.top[i]
        # above the limit a lower frequency gives the same column at these angles (an alias)
        f = scan.top[i] + 1.0
        alias = 360.0 / h - f
        assert abs(np.corrcoef(np.sin(f * q[:, i]), -np.sin(alias * q[:, i]))[0, 1]) > 0.99
    # an arm's joints spread at random: the whole band (no aliases)
    arm = rng.uniform(-2.5, 2.5, (100, 6))
    assert (FrequencyScan(arm, np.arange(100)).top == MAX_FREQUENCY).all()
    assert resolved_frequency(arm[:, 0], 0.3) == _brute_force_resolved(arm[:, 0], 0.3) == MAX_FREQUENCY


def _rows_with_contributions(rms_mm, spread_mm, n_params, poses=100, seed=0):
    """Candidate rows whose per-pose MSE shares (m^2) give exactly ``rms_mm``: a noise common to
    every candidate (large) plus each candidate's own scatter ``spread_mm`` (small)."""
    rng = np.random.default_rng(seed)
    common = rng.uniform(0.5, 1.5, poses)
    rows, contributions = [], []
    for i, (rms, spread, k) in enumerate(zip(rms_mm, spread_mm, n_params, strict=True)):
        share = common + spread * rng.standard_normal(poses)
        share *= (rms * 1e-3) ** 2 / share.sum()
        rows.append({"terms": [f"t{i}"] * bool(i), "n_params": k, "cv_rms_mm": rms, "cv_se_mm": 0.05})
        contributions.append(share)
    return rows, contributions


def test_paired_one_standard_error_rule_prefers_fewer_parameters_within_one_paired_se():
    # geometric 0.2% above the best, the pose-to-pose scatter of the difference large: within
    rows, contrib = _rows_with_contributions([0.501, 0.500, 0.530], [0.5, 0.5, 0.5], [30, 60, 40])
    chosen, best, reason = _choose(rows, contrib)
    assert best == 1 and chosen == 0 and "fewest parameters" in reason
    assert rows[best]["cv_paired_se_mm"] is None
    # the same RMS, but the difference consistent over the poses (small paired SE): the best
    rows, contrib = _rows_with_contributions([0.501, 0.500, 0.530], [0.001, 0.001, 0.001], [30, 60, 40])
    assert _choose(rows, contrib)[0] == 1
    # the paired SE against a brute-force computation: SE of the MSE difference, to RMS (delta), on
    # the shares winsorized at the quantile of all of them
    cap = np.quantile(np.concatenate(contrib), WINSOR_QUANTILE)
    w = [np.minimum(c, cap) for c in contrib]
    robust = [np.sqrt(x.sum()) * 1e3 for x in w]
    assert [r["cv_robust_rms_mm"] for r in rows] == pytest.approx(robust, rel=1e-12)
    d = w[2] - w[1]
    se_mse = np.std(d, ddof=1) * np.sqrt(d.size)
    assert rows[2]["cv_paired_se_mm"] == pytest.approx(se_mse / ((robust[2] + robust[1]) * 1e-3) * 1e3)


def test_a_few_poses_with_large_errors_do_not_decide_the_choice(monkeypatch):
    """The larger model is better on nearly every pose by a consistent 7 %; 3 % of the poses carry
    errors a hundred times the others', 10 % larger with it (a real set's tail: 5 % of the poses
    carried 40 % of the squared error on the Meca500 and IRB 120). On the plain shares the tail
    decides (the smaller model); winsorized, the larger model is chosen."""
    import robocal.calibration.model_selection as selection

    rng = np.random.default_rng(4)
    poses = 400
    typical = rng.uniform(0.5, 1.5, poses)
    tail = rng.random(poses) < 0.03
    shares = []
    for gain, tail_gain in ((1.0, 1.0), (0.93, 1.1)):  # 30 parameters, then 60
        share = typical * gain * (1 + 0.02 * rng.standard_normal(poses))
        share[tail] = 100.0 * tail_gain
        shares.append(share * 1e-8)

    def rows():
        return [{"terms": [], "n_params": 30}, {"terms": ["t1"], "n_params": 60}]

    assert _choose(rows(), shares)[0] == 1
    monkeypatch.setattr(selection, "WINSOR_QUANTILE", 1.0)  # the plain shares
    assert _choose(rows(), shares)[0] == 0


def test_selection_never_accepts_more_than_its_tolerance_above_the_best(monkeypatch):
    # a huge pose-to-pose scatter makes the paired SE large; the cap still holds (on the plain
    # shares: this scatter's shares are not a squared error's, winsorizing them means nothing)
    import robocal.calibration.model_selection as selection

    monkeypatch.setattr(selection, "WINSOR_QUANTILE", 1.0)
    over = 1 + 1.5 * SELECTION_TOLERANCE
    rows, contrib = _rows_with_contributions([0.5 * over, 0.5], [50.0, 50.0], [30, 60])
    chosen, _, _ = _choose(rows, contrib)
    assert rows[0]["cv_paired_se_mm"] > 0.5 * (over - 1) and chosen == 1
    within = 1 + 0.5 * SELECTION_TOLERANCE
    rows, contrib = _rows_with_contributions([0.5 * within, 0.5], [50.0, 50.0], [30, 60])
    assert _choose(rows, contrib)[0] == 0


def test_folds_keep_whole_poses_and_the_measuring_order():
    group = np.repeat(np.arange(40), 3)
    fold = _folds(group, 5, seed=2)
    for g in range(40):
        assert np.unique(fold[group == g]).size == 1
    assert np.array_equal(np.bincount(fold), [24] * 5)
    assert np.array_equal(fold, _folds(group, 5, seed=2))


@pytest.mark.parametrize("errors, expected", [
    (COMPLIANCE_GEAR_BACKLASH, ["compliance", "gear", "backlash"]),
    ((["backlash2", "backlash3"], [2e-4, -2e-4]), ["backlash"]),
    (TRAVEL_CYCLIC, ["travel", "cyclic"]),
], ids=["compliance-gear-backlash", "backlash", "travel-cyclic"])
def test_auto_picks_the_injected_terms_and_leaves_out_the_others(errors, expected):
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(_with_errors(robot, *errors), 160, noise_mm=0.02, n_smr=2, seed=7)
    result = calibrate(robot, sim.data, nongeometric="auto")
    ms = result.model_selection
    assert ms["chosen_terms"] == expected
    assert result.nongeometric["terms"] == expected
    assert len(ms["candidates"]) == 2 ** (4 + ("cyclic" in expected))
    if "cyclic" in expected:
        found = {(c["joint"], round(c["cycles_per_rev"])) for c in ms["cyclic_frequencies"]}
        assert found == {(1, 120), (4, 80)}
    assert result.after["rms"] <= 1.1 * sim.noise_floor_mm


@pytest.mark.parametrize("seed", [1, 2])
def test_auto_chooses_geometric_on_a_robot_without_joint_errors(seed):
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(robot, 160, noise_mm=0.02, seed=seed)
    cal, val = sim.data.split_poses(0.6, seed=0)
    auto = calibrate(robot, cal, validation=val, nongeometric="auto")
    plain = calibrate(robot, cal, validation=val, nongeometric=None)
    assert auto.model_selection["chosen_terms"] == [] and auto.robot.joint_errors is None
    assert auto.validation["rms"] == pytest.approx(plain.validation["rms"], rel=1e-6)
    if seed == 1:  # robust's final fit starts from nominal: the robust geometric calibration itself
        auto = calibrate(robot, cal, method="robust", nongeometric="auto")
        plain = calibrate(robot, cal, method="robust", nongeometric=None)
        assert auto.model_selection["chosen_terms"] == []
        assert np.array_equal(auto.robot.values, plain.robot.values)


def test_linearised_fold_fits_match_nonlinear_fold_calibrations():
    """A candidate's fold error (one Gauss-Newton step from the superset fit, by normal equations)
    agrees with iterating each fold's training poses to convergence with the same parameters and
    the same priors."""
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(_with_errors(robot, *COMPLIANCE_GEAR_BACKLASH), 100, noise_mm=0.02, seed=4)
    fixed = ["compliance", "gear", "backlash", "travel"]
    superset = calibrate(robot, sim.data, nongeometric=",".join(fixed))
    lin = _linearise(superset, candidate_names(6, fixed))
    fold = _folds(lin.group, 5, 0)
    cv = _CrossValidation(lin, fold, 5, None, [[]] * 5, [])
    for cand in _candidates(lin, fixed, False, 1e-7):
        if list(cand.terms) not in (["compliance", "backlash"], [], ["gear", "travel"]):
            continue
        linear = cv.evaluate(cand)["fold_rms_mm"]
        # the candidate's robot: the superset's estimate with the other joint-error terms at zero
        robot_f = superset.state.robot.with_joint_errors(cand.ng_names)
        geometric = [nm for nm in superset.names if nm in robot_f.geometry_names]
        est = superset.space
        mean = dict(zip(est.names, est.prior_mean, strict=True))
        space = ParameterSpace((*geometric, *cand.ng_names)).with_prior(
            prior_sigma(robot_f, [*geometric, *cand.ng_names]),
            [mean.get(nm, 0.0) for nm in (*geometric, *cand.ng_names)], est.noise)
        for f in range(5):
            train, test = (CalibrationProblem(robot_f, sim.data.subset(rows))
                           for rows in (fold != f, fold == f))
            fitted = gauss_newton(train, train.start(robot_f), space)
            errors = test.position_errors(test.start(fitted.state.robot))
            assert fitted.status == Status.CONVERGED
            assert np.sqrt(np.mean(errors**2)) * 1e3 == pytest.approx(linear[f], rel=1e-2)


def test_a_fold_fit_sets_aside_a_column_its_training_poses_cannot_show():
    """A joint-error column the poses of one fold alone carry (zero on every other pose) is held at
    zero in that fold's fit, as a calibration of its training poses would drop it, and kept in the
    other folds' and the full data's fits."""
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(_with_errors(robot, *COMPLIANCE_GEAR_BACKLASH), 100, noise_mm=0.02, seed=4)
    fixed = ["gear"]
    superset = calibrate(robot, sim.data, nongeometric="gear")
    lin = _linearise(superset, candidate_names(6, fixed))
    fold = _folds(lin.group, 5, 0)
    j = lin.k0 + lin.ng_names.index("gear1_s1")
    lin.A[np.repeat(fold, lin.rows) != 0, j] = 0.0  # only fold 0's poses show it
    cv = _CrossValidation(lin, fold, 5, None, [[]] * 5, [])
    cand = next(c for c in _candidates(lin, fixed, False, 1e-7) if c.terms == ("gear",))
    assert j in cand.columns
    for f in range(6):
        columns, zeroed = cv._fold_columns(cand, f)
        assert (j in zeroed) == (f == 0) and (j in columns) == (f != 0)


def test_a_warm_start_delivers_the_model_it_fitted():
    """A joint-error parameter declared but not estimated (here: left out of ``params``) is held
    at zero, not at the warm start's value: the delivered model (which keeps only the estimated
    joint errors) must reproduce the fit's own RMS on its calibration data."""
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(_with_errors(robot, *COMPLIANCE_GEAR_BACKLASH), 80, noise_mm=0.02, seed=9)
    superset = calibrate(robot, sim.data, nongeometric="compliance,gear,backlash")
    left_out = "comp3_6"
    assert abs(superset.robot.get(left_out)) > 1e-5  # the warm start carries a value for it
    params = [nm for nm in superset.names if nm != left_out]
    warm = calibrate(robot, sim.data, params=params, nongeometric="compliance,gear,backlash",
                     warm_start=superset)
    assert left_out not in warm.robot.joint_error_names
    own = np.sqrt(np.mean(np.sum(model_errors(warm.robot, sim.data) ** 2, axis=1))) * 1e3
    assert own == pytest.approx(warm.after["rms"], rel=1e-6)
    cold = calibrate(robot, sim.data, params=params, nongeometric="compliance,gear,backlash")
    assert warm.after["rms"] == pytest.approx(cold.after["rms"], rel=1e-6)


def test_auto_works_for_a_seven_axis_arm():
    robot = _panda_like()
    true = _with_errors(robot, ["backlash2", "backlash7", "travel1", *cyclic_names(6, 100)],
                        [2e-4, -3e-4, 1e-3, 1.5e-4, 1e-4])
    sim = simulate_tracker(true, 200, noise_mm=0.02, n_smr=2, seed=3)
    result = calibrate(robot, sim.data, nongeometric="auto")
    assert result.model_selection["chosen_terms"] == ["backlash", "travel", "cyclic"]
    assert [(c["joint"], round(c["cycles_per_rev"])) for c in result.model_selection["cyclic_frequencies"]] \
        == [(6, 100)]
    assert result.after["rms"] <= 1.1 * sim.noise_floor_mm


def test_warm_start_reaches_the_cold_solution_and_checks_its_input():
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(_with_errors(robot, *COMPLIANCE_GEAR_BACKLASH), 80, noise_mm=0.02, seed=9)
    cold = calibrate(robot, sim.data, nongeometric="compliance,gear,backlash")
    geometric = calibrate(robot, sim.data)
    warm = calibrate(robot, sim.data, nongeometric="compliance,gear,backlash", warm_start=geometric)
    assert warm.names == cold.names and warm.nongeometric["kept"] == cold.nongeometric["kept"]
    assert warm.after["rms"] == pytest.approx(cold.after["rms"], rel=1e-6)
    assert warm.before == cold.before  # judged from the same start model
    planes = simulate_tracker(robot, 40, kind="plane", noise_mm=0.01, seed=1)
    with pytest.raises(IdentificationError, match="same robot"):
        calibrate(robot, planes.data, warm_start=geometric)
    with pytest.raises(IdentificationError, match="warm start goes with named"):
        calibrate(robot, sim.data, nongeometric="cyclic", warm_start=geometric)


@pytest.mark.slow
def test_auto_result_json_report_and_command_line(tmp_path, capsys):
    from robocal.cli import main

    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(_with_errors(robot, ["backlash2", "backlash3"], [2e-4, -2e-4]), 130,
                           noise_mm=0.02, seed=5)
    sim.data.save(tmp_path / "cal.csv")
    rc = main(["--quiet", "calibrate", str(tmp_path / "cal.csv"), "--robot", "abb_irb2600",
               "--nongeometric", "auto", "--hold-out", "30", "--json", str(tmp_path / "r.json"),
               "--report", str(tmp_path / "r.html")])
    out = capsys.readouterr().out
    assert rc == 0 and "error model chosen by 5-fold cross-validation" in out
    assert "chosen (*): backlash" in out
    result = json.loads((tmp_path / "r.json").read_text())
    ms = result["model_selection"]
    assert ms["chosen_terms"] == ["backlash"] and ms["candidates"][ms["chosen"]]["terms"] == ["backlash"]
    assert {"cv_rms_mm", "cv_se_mm", "n_params", "calibration_rms_mm"} <= set(ms["candidates"][0])
    html = (tmp_path / "r.html").read_text()
    assert "Error model selection" in html and "one-standard-error rule" in html
    few = sim.data.first_poses(20)
    with pytest.raises(IdentificationError, match="at least 25 poses"):
        calibrate(robot, few, nongeometric="auto")
    with pytest.raises(IdentificationError, match="lsq, robust"):
        calibrate(robot, sim.data, method="swarm", nongeometric="auto")
    with pytest.raises(IdentificationError, match="unknown non-geometric"):
        calibrate(robot, sim.data, nongeometric="auto,gear")


def test_auto_is_the_default_for_lsq_and_robust_on_tracker_data_with_enough_poses():
    from robocal.calibration.pipeline import AUTO_DEFAULT_MIN_POSES, resolve_nongeometric

    robot = Robot.from_catalog("abb_irb2600")
    many = simulate_tracker(robot, AUTO_DEFAULT_MIN_POSES, noise_mm=0.02, seed=1).data
    few = many.first_poses(AUTO_DEFAULT_MIN_POSES - 1)
    planes = simulate_tracker(robot, AUTO_DEFAULT_MIN_POSES, kind="plane", noise_mm=0.01, seed=1).data
    assert resolve_nongeometric("default", "lsq", [many]) == "auto"
    assert resolve_nongeometric("default", "robust", [many]) == "auto"
    assert resolve_nongeometric("default", "lsq", [few]) is None
    assert resolve_nongeometric("default", "genetic", [many]) is None
    assert resolve_nongeometric("default", "lsq", [planes]) is None
    assert resolve_nongeometric("default", "lsq", [many, planes]) is None  # several sets: name the terms
    assert resolve_nongeometric("none", "lsq", [many]) is None
    assert resolve_nongeometric("gear", "lsq", [few]) == "gear"
    result = calibrate(robot, many)
    assert result.model_selection is not None and result.settings["nongeometric"] == "auto"


def test_explicit_cyclic_term_searches_the_data_and_the_model_round_trips(tmp_path):
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(_with_errors(robot, *TRAVEL_CYCLIC), 120, noise_mm=0.02, seed=2)
    result = calibrate(robot, sim.data, nongeometric="travel,cyclic")
    cyclic = [nm.split("_") for nm in result.nongeometric["kept"] if nm.startswith("cyc")]
    assert {(joint, round(float(f))) for joint, f, _ in cyclic} == {("cyc1", 120), ("cyc4", 80)}
    assert len(cyclic) == 4
    assert result.after["rms"] <= 1.1 * sim.noise_floor_mm
    result.robot.save(tmp_path / "m.yaml")
    back = Robot.load(tmp_path / "m.yaml")
    d = sim.data
    assert back.joint_errors.names == result.robot.joint_errors.names
    assert np.array_equal(back.fk(d.joints, conditions=d.conditions),
                          result.robot.fk(d.joints, conditions=d.conditions))
    clean = simulate_tracker(robot, 60, noise_mm=0.02, seed=2).data
    plain = calibrate(robot, clean, nongeometric="cyclic")
    assert plain.robot.joint_errors is None
    assert any("no significant cyclic error" in w for w in plain.warnings)


def test_a_peak_at_the_bottom_of_the_band_stays_a_cyclic_frequency():
    """A twice-per-revolution error (the gear term's) searched by ``cyclic`` alone peaks at the
    band's lowest frequency; its refinement must not move it below 2 cycles per revolution (it did,
    and the calibration stopped naming a frequency of 1.99)."""
    robot = Robot.from_catalog("abb_irb2600")
    true = _with_errors(robot, ["gear1_s2", "gear1_c2"], [3e-4, 2e-4])
    for seed in (0, 1):
        sim = simulate_tracker(true, 120, noise_mm=0.02, seed=seed)
        result = calibrate(robot, sim.data, nongeometric="cyclic")
        found = [float(nm.split("_")[1]) for nm in result.robot.joint_errors.names]
        assert found and min(found) > 2.0
        assert result.after["rms"] <= 1.1 * sim.noise_floor_mm


def test_a_chosen_model_that_does_not_converge_is_not_chosen(monkeypatch):
    """auto's final fit must converge: a candidate whose final calibration stops at the limit is
    marked in the table (x, not_converged) and the one-standard-error rule picks among the rest."""
    import robocal.calibration.pipeline as calibration

    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(_with_errors(robot, ["backlash2", "backlash3"], [2e-4, -2e-4]), 130,
                           noise_mm=0.02, seed=5)
    real, finals = calibration._calibrate, []

    def first_final_fails(robot, datasets, method, params, terms, validations, warm_start=None, **kw):
        result = real(robot, datasets, method, params, terms, validations, warm_start, **kw)
        if warm_start is not None:  # a final fit (the superset starts cold)
            finals.append(list(terms))
            if len(finals) == 1:
                result.solver = replace(result.solver, status=Status.MAX_ITERATIONS,
                                        message="not converged after 50 iterations")
        return result

    monkeypatch.setattr(calibration, "_calibrate", first_final_fails)
    result = calibrate(robot, sim.data, nongeometric="auto")
    ms = result.model_selection
    failed = [i for i, c in enumerate(ms["candidates"]) if "not_converged" in c]
    assert len(failed) == 1 and ms["chosen"] != failed[0] and len(finals) == 2
    assert ms["candidates"][failed[0]]["parameters"] == finals[0]
    assert result.solver.success and "did not converge" in ms["reason"]
    assert "\nx " in selection_table(ms)


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 400), st.integers(0, 2**32 - 1), st.booleans())
def test_gridded_trig_sums_match_the_direct_sums(n_modes, seed, complex_weights):
    """The frequency scan's non-uniform DFT (gridding + Taylor) against the direct sums."""
    rng = np.random.default_rng(seed)
    P = int(rng.integers(1, 300))
    x = rng.uniform(-20.0, 20.0, P)
    w = rng.normal(size=P) + (1j * rng.normal(size=P) if complex_weights else 0.0)
    direct = np.exp(1j * np.outer(np.arange(n_modes), x)) @ w
    assert np.abs(trig_sums(w, x, n_modes) - direct).max() <= 1e-12 * max(np.abs(w).sum(), 1e-300)
