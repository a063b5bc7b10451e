"""Knowing the limits of an answer: the residual test, change points, conventions and units, the
independence of validation data, the predicted accuracy over the workspace (robocal.trust)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.core.errors import DataError, PlausibilityError
from robocal.data.simulate import simulate_tracker
from robocal.identify.space import block_of
from robocal.trust.consistency import (
    ALPHA,
    change_point,
    held_joint,
    orientation_convention,
    residual_test,
)
from robocal.trust.coverage import Prediction, workspace_sample
from robocal.trust.diagnosis import diagnose, length_unit
from robocal.trust.provenance import JOINT_REPEAT_TOL_DEG, fingerprint, repeated_rows

ROBOT = rc.Robot.from_catalog("abb_irb2600")


@pytest.fixture(scope="module")
def sim():
    return simulate_tracker(ROBOT, 60, seed=4)


def _moved(sim, k: int, delta_flange=None, delta_tracker=None):
    """The simulated data with the SMR moved by ``delta_flange`` (m, flange frame) or the tracker
    shifted by ``delta_tracker`` (m) from row ``k`` on."""
    T = sim.truth.fk(sim.true_joints, smr=sim.data.smr)
    points = sim.data.points.copy()
    if delta_flange is not None:
        points[k:] += np.einsum("nij,j->ni", T[k:, :3, :3], delta_flange)
    if delta_tracker is not None:
        points[k:] += delta_tracker
    return replace(sim.data, points=points)


def _calibrate(data, **kw):
    return rc.calibrate(ROBOT, data, nongeometric="none", **kw)


def test_clean_campaign_is_consistent(sim):
    res = _calibrate(sim.data)
    c = res.to_dict()["consistency"]
    assert c["verdict"] == "consistent" and c["change_points"] == [] and c["diagnosis"] == []
    assert c["p_value"] > ALPHA and c["dof"] == 3 * 60 - res.space.size
    assert not any("misses its data" in w for w in res.warnings)


def test_residual_test_against_brute_force_chi_square():
    rng = np.random.default_rng(0)
    e = rng.normal(size=(400, 3)) * 1e-3
    out = residual_test([e], [np.full(400, 1e-3)], 0, 0.0)
    assert out.dof == 1200 and out.statistic == pytest.approx(float(np.sum(e**2)) / 1e-6)
    assert ALPHA < out.p_value < 1 - ALPHA
    worse = residual_test([2 * e], [np.full(400, 1e-3)], 10, 0.0)
    assert worse.misfit and worse.dof == 1190
    assert not residual_test([2 * e], [np.full(400, 1e-3)], 10, 2e-3).misfit  # the budget explains it


@pytest.mark.parametrize("k", [20, 41])
def test_smr_moved_to_another_nest_is_found_at_its_row(sim, k):
    res = _calibrate(_moved(sim, k, delta_flange=np.array([0.04, 0.0, 0.0])))
    c = res.consistency
    assert c.verdict == "inconsistent" and len(c.change_points) == 1
    cp = c.change_points[0]
    assert abs(cp.index - k) <= 1 and cp.frame == "flange" and cp.step_mm > 20
    assert cp.row == sim.data.source_row[cp.index]
    assert any(f"row {cp.row}" in w and "SMR was moved" in w for w in res.warnings)


def test_smr_reseated_and_tracker_bumped_are_found(sim):
    reseated = _calibrate(_moved(sim, 30, delta_flange=np.array([0.0, 0.0, -0.003]))).consistency
    assert [(abs(c.index - 30) <= 1, c.frame) for c in reseated.change_points] == [(True, "flange")]
    bumped = _calibrate(_moved(sim, 45, delta_tracker=np.array([0.001, 0.0005, 0.0]))).consistency
    assert [(abs(c.index - 45) <= 1, c.frame) for c in bumped.change_points] == [(True, "tracker")]
    assert "bumped" in bumped.diagnosis[0]


def _blocked_scan(blocks: int = 13, turns: int = 16) -> np.ndarray:
    """A positioner's measuring order: the tilt held while the table turns, block after block."""
    tilt = np.repeat(np.deg2rad(np.linspace(-30, 30, blocks)), turns)
    return np.column_stack([tilt, np.tile(np.deg2rad(np.arange(turns) * 360.0 / turns), blocks)])


def _brute_held(q: np.ndarray, k: int, i: int) -> int:
    """Rows joint i stood still before row k (> 0) or from row k on (< 0), counted one by one."""
    tol = np.deg2rad(0.05)
    if abs(q[k, i] - q[k - 1, i]) <= tol:
        return 0
    before = next((n for n in range(1, k + 1) if n == k or abs(q[k - 1 - n, i] - q[k - 1, i]) > tol), k)
    after = next(n for n in range(1, len(q) - k + 1) if n == len(q) - k or abs(q[k + n, i] - q[k, i]) > tol)
    return before if before >= after else -after


def test_held_joint_is_a_blocked_scan_joint_moving_at_the_row():
    q = _blocked_scan()
    for k in range(1, len(q)):
        found = held_joint(q, k, 8)
        expected = _brute_held(q, k, 0)
        assert (found is None) == (abs(expected) < 8)
        if found is not None:
            assert found == (0, q[k - 1, 0] if expected > 0 else q[k, 0], expected)
    arm = np.random.default_rng(0).uniform(-2, 2, (100, 6))
    assert all(held_joint(arm, k, 3) is None for k in range(1, 100))


def test_step_at_a_block_of_a_held_joint_names_the_confound():
    # a 2-axis positioner (tilt, then the table 0.4 m along it) seen by a 6-DOF sensor, the sensor
    # bumped by 0.5 mm where the tilt leaves its first value: a bump, or an error at that tilt
    table = rc.Robot.from_mdh([0, -90], [0, 0], [0, 0], [0, 400], degrees=True, length_unit="mm",
                              tool=np.array([[1, 0, 0, 0.2], [0, 1, 0, 0], [0, 0, 1, 0.05], [0, 0, 0, 1.0]]),
                              limits=[[-90, 90], [-360, 360]])
    q = _blocked_scan()
    T = table.fk(q)
    rng = np.random.default_rng(2)
    points = T[:, :3, 3] + 2e-5 * rng.standard_normal((len(q), 3))
    points[16:] += [5e-4, 0.0, 0.0]
    data = rc.Measurements.from_arrays("pose", q, points=points, rotations=T[:, :3, :3], external=2)
    res = rc.calibrate(table, data, nongeometric=None)
    (cp,) = res.consistency.change_points
    assert cp.index == 16 and cp.joint == "q1" and cp.joint_rows == 16
    assert cp.joint_deg == pytest.approx(-30.0)
    assert any("joint q1 leaves -30 there" in w and "cannot tell the two apart" in w for w in res.warnings)
    assert cp.to_dict()["joint_held"] == "before"


def test_a_target_the_positioner_cannot_move_is_no_unit_mistake():
    # the target where the tilt and turn axes meet: it fits a cloud scaled down by 1000 as closely,
    # relative to its size, as the cloud given; that is no sign of millimetres under _m headers
    table = rc.Robot.from_mdh([0, -90], [0, 0], [0, 0], [0, 400], degrees=True, length_unit="mm",
                              tool=np.array([[1, 0, 0, 0.0], [0, 1, 0, 0], [0, 0, 1, -0.4], [0, 0, 0, 1.0]]),
                              limits=[[-90, 90], [-360, 360]])
    q = _blocked_scan()
    points = table.fk(q)[:, :3, 3] + 1e-4 * np.random.default_rng(1).standard_normal((len(q), 3))
    data = rc.Measurements.from_arrays("point", q, points=points, external=2)
    assert np.ptp(table.fk(q)[:, :3, 3], axis=0).max() < 1e-12  # the target does not move
    assert length_unit(table, data, 0.17) is None
    arm_mm = replace(sim_mm := simulate_tracker(ROBOT, 30, seed=1).data, points=sim_mm.points * 1e3)
    assert "millimetres under _m" in length_unit(ROBOT, arm_mm, 1e5)  # a real unit mistake still named


def test_change_point_of_pure_noise_is_not_reported():
    rng = np.random.default_rng(1)
    R = Rotation.random(200, random_state=2).as_matrix()
    noise = rng.normal(size=(20, 200, 3)) * 2e-5
    fired = sum(change_point(e, R, 2e-5, seed=s) is not None for s, e in enumerate(noise))
    assert fired <= 1
    e = rng.normal(size=(200, 3)) * 2e-5
    e[120:] += [1e-3, 0, 0]  # a 1 mm step in the tracker frame at row 120
    k, frame, step, p, shape = change_point(e, R, 2e-5)
    assert k == 120 and frame == "tracker" and step == pytest.approx(1e-3, rel=0.05) and shape == "step"
    drift = rng.normal(size=(200, 3)) * 2e-5 + np.outer(np.linspace(0, 1e-3, 200), [0, 1, 0])
    assert change_point(drift, R, 2e-5)[4] == "drift"


def test_scalar_last_quaternions_are_refused_and_named():
    sim = simulate_tracker(ROBOT, 40, seed=4, kind="pose", rotation_noise_deg=0.01)
    q = Rotation.from_matrix(sim.data.rotations).as_quat()  # x, y, z, w
    bad = replace(sim.data, rotations=Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix())  # file: x,y,z,w
    assert orientation_convention(sim.truth, sim.data) is None
    with pytest.raises(PlausibilityError, match="worse than the nominal.*scalar-last"):
        _calibrate(bad)
    forced = _calibrate(bad, force=True)
    assert forced.after["rms"] > forced.before["rms"]
    assert any("FORCED" in w and "scalar-last" in w for w in forced.warnings)
    inverse = replace(sim.data, rotations=np.swapaxes(sim.data.rotations, 1, 2))
    assert "inverse rotations" in orientation_convention(ROBOT, inverse)


def test_inches_are_diagnosed(sim):
    inches = replace(sim.data, points=sim.data.points / 25.4)
    assert "inches under _mm" in diagnose(ROBOT, [inches])
    forced = _calibrate(inches, force=True)
    assert forced.consistency.misfit and "inches under _mm" in forced.consistency.diagnosis[0]


def test_fingerprints_and_repeated_rows():
    rng = np.random.default_rng(3)
    q = rng.uniform(-2, 2, (30, 6))
    assert fingerprint(q) == fingerprint(q.copy()) != fingerprint(q[::-1])
    near = q[:5] + np.deg2rad(JOINT_REPEAT_TOL_DEG) * 0.5
    far = q[:5] + np.deg2rad(JOINT_REPEAT_TOL_DEG) * 2
    found = repeated_rows(q, np.vstack([near, far, rng.uniform(-2, 2, (3, 6))]))
    assert found.tolist() == [True] * 5 + [False] * 8
    # brute force: any reference row within the tolerance on every joint
    other = np.vstack([q[::3] + rng.normal(0, 1e-5, (10, 6)), rng.uniform(-2, 2, (10, 6))])
    brute = (np.abs(other[:, None] - q[None]).max(axis=2) <= np.deg2rad(JOINT_REPEAT_TOL_DEG)).any(axis=1)
    assert repeated_rows(q, other).tolist() == brute.tolist()


def test_validation_repeating_calibration_poses_is_judged_on_the_rest(sim):
    cal, val = sim.data.subset(np.arange(40)), sim.data.subset(np.arange(28, 60))  # 12 rows shared
    res = _calibrate(cal, validation=val)
    indep = res.to_dict()["validation_independence"][0]
    assert (indep["rows"], indep["repeated_rows"], indep["rows_judged"]) == (32, 12, 20)
    assert res.validation["n"] == 20
    assert any("12 of its 32 rows repeat calibration poses" in w for w in res.warnings)
    independent = _calibrate(cal, validation=sim.data.subset(np.arange(40, 60)))
    assert res.validation["rms"] == pytest.approx(independent.validation["rms"])
    with pytest.raises(DataError, match="every one of its 10 rows repeats a calibration pose"):
        _calibrate(cal, validation=sim.data.subset(np.arange(10)))


def _clustered(n: int, seed: int, truth=None):
    """Poses within +-3 deg of one pose (of ``truth``, else a new perturbed robot)."""
    rng = np.random.default_rng(seed)
    q = np.deg2rad([10, 20, 10, 30, 40, 50]) + np.deg2rad(rng.uniform(-3, 3, (n, 6)))
    if truth is None:
        return simulate_tracker(ROBOT, joints=q, seed=seed)
    return simulate_tracker(truth, joints=q, seed=seed, as_is=True)


def test_clustered_poses_hold_only_near_them():
    cal = _clustered(60, 5)
    res = _calibrate(cal.data, validation=_clustered(20, 6, cal.truth).data)
    pa = res.to_dict()["predicted_accuracy"]
    assert pa["holds_only_near_poses"] and pa["validated_from"] == "on the validation data"
    assert pa["calibration_region"]["rms"] < 0.1 < 1.0 < pa["workspace"]["rms"]
    assert pa["ratio"] > pa["factor"] == 3.0
    assert any(w.startswith("the calibration holds only near its poses") and "q5 (covered 37..43" in w
               for w in res.warnings)
    # the truth: the calibrated model is far off over the workspace, the prediction says so
    q = workspace_sample(ROBOT)
    true = np.linalg.norm(cal.truth.fk(q)[:, :3, 3] - res.robot.fk(q)[:, :3, 3], axis=1) * 1e3
    assert np.sqrt(np.mean(true**2)) > 10 * res.validation["rms"]
    assert pa["by_distance"]["rms_mm"][-1] > pa["by_distance"]["rms_mm"][0]


def test_spread_poses_hold_over_the_workspace(sim):
    val = simulate_tracker(sim.truth, 20, seed=9, as_is=True).data
    res = _calibrate(sim.data, validation=val)
    pa = res.predicted_accuracy
    assert not pa["holds_only_near_poses"] and pa["ratio"] < 2
    assert not any("holds only near" in w for w in res.warnings)
    q = workspace_sample(ROBOT)
    true = np.linalg.norm(sim.truth.fk(q)[:, :3, 3] - res.robot.fk(q)[:, :3, 3], axis=1) * 1e3
    assert np.sqrt(np.mean(true**2)) < pa["workspace"]["rms"]  # prediction includes the tracker noise


def test_prediction_round_trips_and_matches_the_propagation(sim):
    res = _calibrate(sim.data)
    pred = Prediction.from_dict(res.to_dict()["predicted_accuracy"]["model"])
    q = workspace_sample(ROBOT, 50, seed=3)
    beyond = pred.error_mm(res.robot, q) > 3.0 * pred.validated_mm
    assert pred.beyond(res.robot, q).tolist() == beyond.tolist()
    # brute force: per pose, the 3x3 covariance from the finite-difference Jacobian (link parameters:
    # with_values moves them additively; the frames are multiplicative)
    keep = [i for i, n in enumerate(pred.names) if block_of(n) == "links"]
    pred = replace(pred, names=tuple(pred.names[i] for i in keep),
                   covariance=pred.covariance[np.ix_(keep, keep)])
    e = pred.error_mm(res.robot, q)
    names, C = list(pred.names), pred.covariance
    G = np.zeros((50, 3, len(names)))
    for j, n in enumerate(names):
        h = 1e-7
        plus, minus = (res.robot.with_values({n: res.robot.get(n) + s}) for s in (h, -h))
        G[:, :, j] = (plus.fk(q)[:, :3, 3] - minus.fk(q)[:, :3, 3]) / (2 * h)
    brute = np.sqrt(np.einsum("nik,kl,nil->n", G, C, G) + (pred.unmodelled_mm * 1e-3) ** 2) * 1e3
    np.testing.assert_allclose(e, brute, rtol=1e-4)
    with pytest.raises(DataError, match="malformed"):
        Prediction.from_dict({"names": ["a2"], "covariance_si": [[1.0, 2.0]]})


@pytest.mark.slow
def test_cli_clustered_calibration_warns_and_compensate_warns_per_target(tmp_path, capsys):
    from robocal.cli import main
    from robocal.deploy.compensation import format_csv, pose_columns

    cal = _clustered(60, 5)
    cal.data.save(tmp_path / "cal.csv")
    _clustered(20, 6, cal.truth).data.save(tmp_path / "val.csv")
    assert main(["calibrate", str(tmp_path / "cal.csv"), "--robot", "abb_irb2600", "--validate",
                 str(tmp_path / "val.csv"), "--nongeometric", "none", "-o", str(tmp_path / "cal.yaml"),
                 "--json", str(tmp_path / "r.json"), "--report", str(tmp_path / "r.html")]) == 0
    out = capsys.readouterr().out
    assert "predicted accuracy:" in out and "WARNING: the calibration holds only near its poses" in out
    assert "Predicted accuracy over the workspace" in (tmp_path / "r.html").read_text()
    # targets: one near the calibration poses, one far from them (flange poses of the nominal model)
    q = np.deg2rad([[10, 20, 10, 30, 40, 50], [-90, 60, -40, -100, -70, 120]])
    names, values = pose_columns(ROBOT.fk(q), {"length": "mm", "orientation": "quat"})
    (tmp_path / "t.csv").write_text(format_csv(names, values))
    assert main(["compensate", str(tmp_path / "cal.yaml"), str(tmp_path / "t.csv"), "--nominal",
                 "abb_irb2600", "--result", str(tmp_path / "r.json"), "-o", str(tmp_path / "c.csv")]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "predicted error exceeds" in ln]
    assert len(line) == 1 and "1 of 2 targets" in line[0] and "targets 2 (" in line[0]
    # the same two targets in a RAPID module: filter warns the same way
    T = ROBOT.fk(q)
    quats = Rotation.from_matrix(T[:, :3, :3]).as_quat(scalar_first=True)
    targets = [f"    CONST robtarget p{k}:=[[{','.join(f'{v:.3f}' for v in T[k, :3, 3] * 1e3)}],"
               f"[{','.join(f'{v:.8f}' for v in quats[k])}],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];"
               for k in range(2)]
    module = ["MODULE Cell", *targets, "    PROC main()", "        MoveJ p0, v1000, fine, tool0;",
              "        MoveL p1, v500, fine, tool0;", "    ENDPROC", "ENDMODULE", ""]
    (tmp_path / "cell.mod").write_text("\n".join(module))
    assert main(["filter", str(tmp_path / "cell.mod"), "--calibrated", str(tmp_path / "cal.yaml"),
                 "--nominal", "abb_irb2600", "--result", str(tmp_path / "r.json"), "-o",
                 str(tmp_path / "cell_cal.mod")]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "predicted error exceeds" in ln]
    assert len(line) == 1 and "1 of 2 targets" in line[0] and "targets 2 (" in line[0]


def test_evaluate_reports_the_residual_test(sim):
    from robocal.calibration.evaluation import evaluate

    stats = evaluate(ROBOT, sim.data, fit_frame=True)
    assert stats["consistency"]["dof"] == 3 * 60 - 9 and stats["consistency"]["verdict"] == "consistent"
    moved = evaluate(ROBOT, _moved(sim, 30, delta_tracker=np.array([0.002, 0.0, 0.0])), fit_frame=True)
    assert moved["consistency"]["change_points"][0]["frame"] == "tracker"
    assert any("bumped" in w for w in moved["warnings"])


def test_information_covariance_equals_the_svd_posterior():
    from robocal.identify.priors import posterior_covariance
    from robocal.trust.coverage import information_covariance

    rng = np.random.default_rng(5)
    J = rng.normal(size=(300, 8)) * np.logspace(-4, 2, 8)
    J[:, 7] = J[:, 6] * 3.0  # a confounded pair, separated by the prior on one of them
    w = np.array([0, 0, 1e-3, 0, 2.0, 0, 0.5, 0])
    got, want = information_covariance(J, w, 0.7), posterior_covariance(J, w, 0.7)
    # entries span 1e-15 .. 1.8e5 (columns scaled 1e-4 .. 1e2): an entry-wise rtol would ask for
    # digits below float64 resolution at the matrix's scale (another BLAS, another last digit).
    # The difference is judged relative to the matrix norm, and each entry relative to its own
    # scale sqrt(C_ii C_jj) (the columns' scaling divided out): both are ~1e-16 here.
    assert np.linalg.norm(got - want) <= 1e-9 * np.linalg.norm(want)
    scale = np.sqrt(np.outer(np.diag(want), np.diag(want)))
    assert np.all(np.abs(got - want) <= 1e-9 * scale)


def test_rejected_outliers_do_not_inflate_the_workspace_prediction():
    """A robust fit that rejected gross outliers: the prediction's unmodelled error and scale come
    from the inliers (the demo's campaign warned 'holds only near its poses' at 7x before)."""
    robot = rc.Robot.from_catalog("abb_irb2600")
    sim = rc.simulate_tracker(robot, 80, outliers=0.06, seed=5)
    check = rc.simulate_tracker(sim.truth, 60, as_is=True, seed=6)
    result = rc.calibrate(robot, sim.data, method="robust", validation=check.data)
    assert result.rejected.size > 0
    predicted = result.predicted_accuracy
    assert not predicted["holds_only_near_poses"]
    assert predicted["workspace"]["rms"] < 2.0 * result.validation["rms"]


def test_worse_than_nominal_on_validation_needs_more_than_sampling_scatter():
    from robocal.calibration.pipeline import significantly_worse

    rng = np.random.default_rng(7)
    # the same error law before and after on 40 items: called worse in about 1 % of the trials
    same = [significantly_worse(*np.abs(rng.normal(0, 1e-5, (2, 40)))) for _ in range(4000)]
    assert 0.002 < np.mean(same) < 0.025
    worse = [significantly_worse(np.abs(rng.normal(0, 1e-5, 40)), np.abs(rng.normal(0, 2e-5, 40)))
             for _ in range(400)]
    assert np.mean(worse) > 0.8
    # the ROS-Industrial positioner's nominal chain, whose simulated errors its frames absorb: a
    # calibration that changes nothing the data see is not "worse than the nominal" because its
    # held-out RMS moved by 3 %
    base = np.eye(4)
    base[:3, :3] = Rotation.from_rotvec([np.pi / 2, 0, 0]).as_matrix()
    base[:3, 3] = [0.0, -0.7, 0.525]
    tool = np.eye(4)
    tool[:3, :3] = Rotation.from_quat([0.447585, -0.547419, -0.447585, 0.547419]).as_matrix()
    tool[:3, 3] = [0.17, -0.65, 0.5]
    table = rc.Robot.from_dh([0, -np.pi / 2], [0, -0.475], [0, 0], [-np.pi / 2, 0], base=base, tool=tool,
                             limits=[[-np.pi, np.pi], [-2 * np.pi, 2 * np.pi]])
    sim = simulate_tracker(table, 200, kind="pose", noise_mm=0.02, rotation_noise_deg=0.005, seed=3)
    cal, held = sim.data.split_poses(0.8, seed=1)
    res = rc.calibrate(table, cal, validation=held)
    judged = res.judged[0]
    assert judged.before["rms"] < judged.after["rms"] < 1.05 * judged.before["rms"]
    assert not any("worse than the nominal on the validation" in w for w in res.warnings)
