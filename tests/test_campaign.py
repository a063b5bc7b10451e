"""``rc.plan_poses``: constraints, the tracker's line of sight, the information model, the
predicted accuracy against real calibrations, and the error messages."""

from __future__ import annotations

import numpy as np
import pytest
from robots import require_datasets

import robocal as rc
from robocal import DataError, Robot
from robocal.campaign import Constraints, Tracker, plan_poses
from robocal.campaign.constraints import _segment_point_distance, segment_segment_distance, smr_geometry
from robocal.data.measurements import Measurements
from robocal.data.simulate import _tracker_noise, simulate_tracker
from robocal.ik.singularity import classic_distances, singularity_distance
from robocal.trust.posterior import Noise

IRB = Robot.from_catalog("abb_irb2600")
MECA = Robot.from_catalog("meca500")
SMR = np.array([0.02, -0.03, 0.08])


def _model_error(calibrated, truth, q) -> float:
    """3-D RMS (m) of the calibrated model's TCP against the truth (noise free)."""
    e = calibrated.fk(q)[:, :3, 3] - truth.fk(q)[:, :3, 3]
    return float(np.sqrt(np.mean(np.sum(e**2, axis=1))))


@pytest.mark.slow
def test_plan_is_deterministic_in_the_limits_and_better_than_random():
    a = plan_poses(IRB, 14, smr=SMR, n_candidates=1500, seed=3, curve=(11, 20))
    b = plan_poses(IRB, 14, smr=SMR, n_candidates=1500, seed=3)
    np.testing.assert_array_equal(a.joints, b.joints)
    lim = np.deg2rad(1.0)
    assert (a.joints >= IRB.limits[:, 0] + lim - 1e-12).all()
    assert (a.joints <= IRB.limits[:, 1] - lim + 1e-12).all()
    assert a.identifiability.rank == 27 and a.n == 14
    planned = [p.predicted_rms_mm for p in a.curve]
    assert all(x >= y - 1e-12 for x, y in zip(planned, planned[1:], strict=False))  # more poses, better
    assert all(p.random_median_mm > p.predicted_rms_mm for p in a.curve)
    assert a.travel <= a.travel_unordered
    point = next(p for p in a.curve if p.n == 14)
    assert point.predicted_rms_mm == pytest.approx(a.predicted_rms_mm)


@pytest.mark.slow
def test_predicted_accuracy_matches_real_calibrations():
    """Plan, simulate the planned poses on perturbed robots, calibrate with lsq: the RMS of the
    true model error over the region agrees with the prediction (mean square over repeats)."""
    result = plan_poses(IRB, 16, smr=SMR, n_candidates=1500, seed=1, region_size=500)
    rng = np.random.default_rng(0)
    q_eval = rng.uniform(IRB.limits[:, 0] + 0.02, IRB.limits[:, 1] - 0.02, (1000, 6))
    errors = []
    for seed in range(16):
        sim = simulate_tracker(IRB, joints=result.joints, smr_offsets=SMR, noise_mm=0.02, seed=seed)
        cal = rc.calibrate(IRB, sim.data)
        errors.append(_model_error(cal.robot, sim.truth, q_eval) * 1e3)
    achieved = float(np.sqrt(np.mean(np.square(errors))))
    assert achieved == pytest.approx(result.predicted_rms_mm, rel=0.25)


@pytest.mark.slow
def test_tracker_line_of_sight_and_boxes_hold_for_every_chosen_pose():
    tracker = Tracker(position=[2.4, 0.6, 0.4], acceptance_deg=30.0, range_m=(0.5, 10.0))
    box = ((0.4, -1.2, 0.0), (1.8, 1.2, 1.9))
    smr = np.array([[0.02, -0.03, 0.08], [-0.05, 0.05, 0.06]])
    normals = np.array([[0.0, 0.0, 1.0], [-0.5, 0.5, 0.7]])
    res = plan_poses(IRB, 15, smr=smr, smr_normals=normals, n_candidates=800,
                     constraints=Constraints(tracker=tracker, boxes=(box,), min_joint_distance_deg=15.0,
                                             min_wrist_deg=10.0))
    pos, nrm, _ = smr_geometry(IRB, res.joints, smr, normals / np.linalg.norm(normals, axis=1)[:, None])
    for k in range(len(res.joints)):  # an independent loop over poses and SMRs
        for s in range(2):
            d = tracker.position - pos[k, s]
            angle = np.degrees(np.arccos(d @ nrm[k, s] / np.linalg.norm(d)))
            assert res.visible[k, s] == (angle <= 30.0)
    assert res.visible.any(axis=1).all()
    tcp = pos[:, 0]
    assert ((tcp >= np.array(box[0])) & (tcp <= np.array(box[1]))).all()
    qd = np.rad2deg(res.joints)
    gaps = np.linalg.norm(qd[:, None] - qd[None], axis=2) + np.eye(len(qd)) * 1e9
    assert gaps.min() >= 15.0
    assert _measures(IRB, res.joints)["wrist_deg"].min() >= 10.0
    assert res.funnel.steps and res.funnel.left >= res.n_candidates


def _measures(robot, q) -> dict:
    return classic_distances(robot.fk(q, frames=True)[1])


def test_singularity_measures_against_the_arm_jacobian():
    q = np.random.default_rng(2).uniform(IRB.limits[:, 0], IRB.limits[:, 1], (200, 6))
    m = _measures(IRB, q)
    folded = np.minimum(np.abs(np.rad2deg(q[:, 4])) % 180, 180 - np.abs(np.rad2deg(q[:, 4])) % 180)
    np.testing.assert_allclose(m["wrist_deg"], folded, atol=1e-6)  # ABB: J5 = 0 is the wrist singularity
    # every configuration where the wrist point's 3x3 Jacobian (joints 1-3) is singular is either
    # an elbow (stretched / folded arm) or a shoulder (wrist centre on axis 1) singularity
    names = ["theta1", "theta2", "theta3"]

    def det(q3):
        qq = np.array([[0.3, 0.2, q3, 0.1, 0.5, 0.2]])
        _, frames = IRB.fk(qq, frames=True)
        wrist = IRB.with_frames(tool=np.linalg.inv(frames[0, 6]) @ frames[0, 4])
        return np.linalg.det(wrist.jacobian(qq, names)[0])

    grid = np.linspace(-np.pi, np.pi, 720)
    dets = np.array([det(v) for v in grid])
    kinds = set()
    for k in np.flatnonzero(np.sign(dets[:-1]) != np.sign(dets[1:])):
        lo, hi = grid[k], grid[k + 1]
        for _ in range(60):  # bisection on the sign change of det
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if np.sign(det(mid)) == np.sign(det(lo)) else (lo, mid)
        s = _measures(IRB, np.array([[0.3, 0.2, lo, 0.1, 0.5, 0.2]]))
        assert min(s["elbow_deg"][0], s["shoulder_mm"][0]) < 1e-6
        kinds.add("elbow" if s["elbow_deg"][0] < 1e-6 else "shoulder")
    assert kinds == {"elbow", "shoulder"}
    assert np.median(m["elbow_deg"]) > 10 and np.median(m["shoulder_mm"]) > 100



@pytest.mark.parametrize("name", ["ur5", "puma560", "abb_irb2600"])
def test_every_zero_of_the_jacobian_determinant_is_a_classic_singularity(name):
    # offset wrists (UR: frames {4} and {5} apart) and sideways offsets (UR d4, PUMA 560 d3): along
    # sweeps of joints 2-4, det J (6 x 6) changes sign only where a classic distance is zero
    robot = Robot.from_catalog(name)
    names = [f"theta{i + 1}" for i in range(6)]

    def det(q):
        return np.linalg.det(robot.jacobian(q, names, kind="pose"))

    rng = np.random.default_rng(4)
    kinds = set()
    for q0 in rng.uniform(0.7 * robot.limits[:, 0], 0.7 * robot.limits[:, 1], (3, 6)):
        for j in (1, 2, 3):
            sweep = np.repeat(q0[None], 721, axis=0)
            sweep[:, j] = np.linspace(*robot.limits[j], 721)
            d = det(sweep)
            for k in np.flatnonzero(np.sign(d[:-1]) != np.sign(d[1:])):
                lo, hi = sweep[k].copy(), sweep[k + 1].copy()
                for _ in range(60):  # bisection on the sign change of det
                    mid = 0.5 * (lo + hi)
                    lo, hi = (mid, hi) if np.sign(det(mid[None])[0]) == np.sign(d[k]) else (lo, mid)
                m = _measures(robot, lo[None])
                score = {"wrist": m["wrist_deg"][0], "elbow": m["elbow_deg"][0],
                         "shoulder": m["shoulder_mm"][0]}
                assert min(score.values()) < 1e-6, (name, j, score)
                kinds.add(min(score, key=score.get))
    assert kinds == {"elbow", "shoulder"}
    far = rng.uniform(0.7 * robot.limits[:, 0], 0.7 * robot.limits[:, 1], (50, 6))
    s, m = singularity_distance(robot, far), _measures(robot, far)
    for key in ("wrist_deg", "elbow_deg", "shoulder_mm"):
        np.testing.assert_array_equal(getattr(s, key), m[key])


def test_planned_poses_keep_the_elbow_and_shoulder_distances():
    res = plan_poses(Robot.from_catalog("ur5"), 12, smr=[0.01, 0.02, 0.05], n_candidates=400, starts=1,
                     constraints=Constraints(min_elbow_deg=20.0, min_shoulder_m=0.15))
    m = _measures(res.robot, res.joints)
    assert m["elbow_deg"].min() >= 20.0 and m["shoulder_mm"].min() >= 150.0
    removed = dict(res.funnel.steps)
    assert removed["the elbow singularity distance (>= 20 deg)"] > 0
    assert removed["the shoulder singularity distance (>= 150 mm)"] > 0
    ur5 = Robot.from_catalog("ur5")
    short = Robot(alpha=ur5.alpha[:4], a=ur5.a[:4], beta=ur5.beta[:4], theta=ur5.theta[:4], d=ur5.d[:4],
                  limits=ur5.limits[:4])
    with pytest.raises(DataError, match="shoulder singularity distance needs a chain of at least 5 joints"):
        plan_poses(short, 12, n_candidates=200, constraints=Constraints(min_shoulder_m=0.1))


def test_the_funnel_counts_the_candidates_the_search_chose_from():
    # the last batch of drawn candidates overshoots the count asked for: the surplus is a funnel
    # step, so what the funnel leaves is what the search saw (it said "1012 left" of 1000)
    box = ((0.4, -1.2, 0.0), (1.8, 1.2, 1.9))
    res = plan_poses(IRB, 12, smr=SMR, n_candidates=1000, starts=1, constraints=Constraints(boxes=(box,)))
    steps = dict(res.funnel.steps)
    assert steps["keeping the 1000 asked for"] > 0
    assert res.funnel.left == res.n_candidates == 1000
    assert res.funnel.text().endswith("; 1000 left") and "from 1000 candidates" in res.summary()
    assert res.to_dict()["candidates"]["left"] == 1000

def test_segment_distances_against_sampling():
    rng = np.random.default_rng(3)
    for _ in range(20):
        a, b, c, d, p = rng.normal(size=(5, 3))
        t = np.linspace(0, 1, 801)
        s1 = a + t[:, None] * (b - a)
        s2 = c + t[:, None] * (d - c)
        brute = np.linalg.norm(s1[:, None] - s2[None], axis=2).min()
        assert segment_segment_distance(a, b, c, d) == pytest.approx(brute, abs=3e-3)
        assert segment_segment_distance(a, b, c, d) <= brute + 1e-12
        nearest = np.linalg.norm(s1 - p, axis=1).min()
        assert _segment_point_distance(a, b, p) == pytest.approx(nearest, abs=3e-3)


def test_tracker_noise_whitener_matches_the_simulated_tracker():
    p = np.array([[0.8, -0.4, 0.6]])
    tracker = np.array([2.0, 1.0, 0.5])
    W = Noise(model="tracker", tracker_position=tracker).whitener(p)[0]
    draws = _tracker_noise(np.repeat(p - tracker, 40000, axis=0), np.random.default_rng(0))
    cov = np.cov(draws.T)
    np.testing.assert_allclose(np.linalg.inv(W.T @ W), cov, rtol=0.05, atol=0.03 * np.abs(cov).max())


@pytest.mark.slow
def test_pose_and_tracker_noise_plans_and_plane_candidates():
    pose = plan_poses(MECA, 12, kind="pose", smr=[0.01, 0.0, 0.03], n_candidates=600, starts=2)
    assert pose.identifiability.rank > 27 and pose.kind == "pose"
    tracked = plan_poses(MECA, 14, smr=[0.01, 0.0, 0.03], n_candidates=600, noise_model="tracker",
                         constraints=Constraints(tracker=Tracker(position=[1.2, 0.3, 0.4])), starts=2)
    assert tracked.predicted_rms_mm < 0.05
    sim = simulate_tracker(MECA, 90, kind="plane", n_planes=3, seed=8, noise_mm=0.0)
    planes = plan_poses(MECA, 40, kind="plane", candidates=sim.data, noise_mm=0.01, starts=2)
    assert len(planes.joints) == 40 and np.isin(planes.candidate_index, np.arange(90)).all()
    np.testing.assert_array_equal(planes.joints, sim.data.joints[planes.candidate_index])
    with pytest.raises(DataError, match="come from a measurement file of plane data"):
        plan_poses(MECA, 20, kind="plane")


def test_candidates_given_as_measurements_are_chosen_exactly():
    sim = simulate_tracker(MECA, 120, n_smr=2, seed=4)  # two rows (SMRs) per pose
    res = plan_poses(MECA, 15, candidates=sim.data, starts=2)
    poses = sim.data.joints[np.unique(sim.data.pose_id, return_index=True)[1]]
    np.testing.assert_array_equal(res.joints, poses[res.candidate_index])
    assert len(set(res.candidate_index.tolist())) == 15


def test_poses_from_a_file_keep_their_limits_unless_a_margin_is_asked_for():
    q = np.random.default_rng(6).uniform(MECA.limits[:, 0], MECA.limits[:, 1], (60, 6))
    q[:5, 4] = MECA.limits[4, 1]  # taught at the J5 limit
    kept = plan_poses(MECA, 12, candidates=q, starts=1)
    assert kept.funnel.left == 60 and kept.settings["margin_deg"] == 0.0
    trimmed = plan_poses(MECA, 12, candidates=q, starts=1, constraints=Constraints(margin_deg=1.0))
    assert trimmed.funnel.left == 55 and not np.isin(trimmed.candidate_index, np.arange(5)).any()


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"constraints": Constraints(margin_deg=200.0)}, "margin of 200 deg leaves no room on joint"),
    ({"constraints": Constraints(boxes=(((5.0, 5.0, 5.0), (6.0, 6.0, 6.0)),))}, "removed by the TCP box"),
    ({"constraints": Constraints(tracker=Tracker(position=[0.05, 0.0, 0.2]))}, "inside the robot"),
    ({"constraints": Constraints(tracker=Tracker(position=[90.0, 0.0, 0.0]))}, "beyond its range"),
    ({"constraints": Constraints(tracker=Tracker(position=[1.5, 0, 0.5], acceptance_deg=0.01))},
     "removed by the tracker line of sight"),
])
def test_constraints_that_remove_everything_are_named(kwargs, message):
    with pytest.raises(DataError, match=message):
        plan_poses(MECA, 15, n_candidates=200, **kwargs)


def test_too_few_poses_and_candidates_are_refused():
    with pytest.raises(DataError, match="plan at least 10 poses"):
        plan_poses(IRB, 9, smr=SMR, n_candidates=300)
    with pytest.raises(DataError, match="only 12 candidates"):
        plan_poses(IRB, 15, smr=SMR, candidates=IRB.limits.mean(axis=1) + np.random.default_rng(0).uniform(
            -1, 1, (12, 6)))
    with pytest.raises(DataError, match="minimum joint distance"):
        plan_poses(MECA, 15, n_candidates=300, constraints=Constraints(min_joint_distance_deg=400.0))


def test_real_meca500_selection_from_joints_alone():
    root = require_datasets()
    from robocal.data.datasets import meca500

    cal, val = meca500(root)
    res = plan_poses(MECA, 20, candidates=cal, smr=[0.0, 0.0, 0.05], region=cal.joints, starts=2)
    chosen = cal.subset(np.flatnonzero(np.isin(cal.pose_id, cal.pose_id[res.candidate_index])))
    assert chosen.n_poses == 20
    np.testing.assert_array_equal(np.sort(chosen.joints, axis=0), np.sort(res.joints, axis=0))
    result = rc.calibrate(MECA, chosen, validation=val)
    assert result.validation["rms"] < 0.055  # 20 random poses: median about 0.06 mm


def test_given_tracker_and_smrs_reach_the_simulation():
    q = plan_poses(MECA, 12, smr=[0.01, 0.02, 0.03], n_candidates=300, starts=1).joints
    sim = simulate_tracker(MECA, joints=q, smr_offsets=[[0.01, 0.02, 0.03], [0.0, -0.05, 0.02]],
                           visible=np.c_[np.ones(12, bool), np.arange(12) % 2 == 0],
                           tracker_position=[1.5, -0.5, 0.3], noise_mm=0.0, error_scale=0.0, seed=2)
    data: Measurements = sim.data
    assert len(data) == 18 and (data.smr[data.pose_id % 2 == 1] == 0).all()
    np.testing.assert_allclose(sim.truth.tool[:3, 3], [0.01, 0.02, 0.03])
    tracker_in_base = np.linalg.inv(sim.truth.base)[:3, 3]
    np.testing.assert_allclose(tracker_in_base, [1.5, -0.5, 0.3], atol=1e-12)
    np.testing.assert_array_equal(data.joints[data.smr == 0], q)


def test_an_smr_in_millimetres_given_as_metres_is_refused_by_the_api():
    """``plan_poses(smr=...)`` checks the SMR offsets' magnitude (m) as ``poses --smr-mm`` does its mm."""
    from robocal.core.errors import UnitError

    with pytest.raises(UnitError, match=r"smr\[0\]: 30 m is too large"):
        plan_poses(MECA, 12, smr=[10.0, 0.0, 30.0], n_candidates=300, starts=1)
