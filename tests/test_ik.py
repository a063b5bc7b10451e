"""Closed-form OPW IK and numeric IK: FK round trips (random and singular poses), branch slots
against py-opw-kinematics, limits and 2 pi copies, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from robots import KERNELS, random_robot, wrapped

import robocal as rc
from robocal.core.errors import DataError, ModelError, UnreachableError
from robocal.data.simulate import perturbed
from robocal.ik import solve_all
from robocal.kinematics.kernels import use_kernels
from robocal.kinematics.transforms import make_transform, pose_error, rotvec_to_matrix

OPW_ROBOTS = ["abb_irb2600", "kuka_kr6_r700", "fanuc_lrmate200id", "puma560"]


def fk_errors(robot, sols, T):
    """Position (m) and rotation (rad) errors of every existing solution ``(N, B, 6)``."""
    ok = np.isfinite(sols).all(axis=2)
    n_idx, b_idx = np.nonzero(ok)
    e = pose_error(T[n_idx], robot.fk(sols[n_idx, b_idx]))
    return np.linalg.norm(e[:, :3], axis=1), np.linalg.norm(e[:, 3:], axis=1)


def recovered(sols, q):
    d = np.abs(wrapped(sols - q[:, None, :])).max(axis=2)
    return np.nanmin(np.where(np.isfinite(d), d, np.inf), axis=1) < 1e-7


@pytest.mark.parametrize("name", OPW_ROBOTS)
def test_random_round_trip(name, kernels):
    robot = rc.Robot.from_catalog(name)
    rng = np.random.default_rng(7)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (3000, 6))
    T = robot.fk(q)
    sols = solve_all(robot, T)
    assert sols.shape == (3000, 8, 6)
    assert recovered(sols, q).all()
    dp, dr = fk_errors(robot, sols, T)
    assert dp.max() < 1e-9 and dr.max() < 1e-9


@pytest.mark.parametrize("name", OPW_ROBOTS)
def test_slots_match_py_opw(name, kernels):
    popw = pytest.importorskip("py_opw_kinematics")
    from scipy.spatial.transform import RigidTransform

    robot = rc.Robot.from_catalog(name)
    o = robot.opw
    model = popw.KinematicModel(a1=o.a1, a2=o.a2, b=o.b, c1=o.c1, c2=o.c2, c3=o.c3,
                                c4=o.c4, offsets=tuple(o.offsets),
                                flip_axes=tuple(s < 0 for s in o.signs))
    rng = np.random.default_rng(3)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (2000, 6))
    T = robot.fk(q)
    ours = solve_all(robot, T)
    theirs = popw.Robot(model, degrees=False).reach(
        RigidTransform.from_matrix(np.linalg.inv(robot.base) @ T)).joints  # catalog TCP = OPW flange
    found = np.isfinite(theirs).all(axis=2)
    same = np.abs(wrapped(ours - theirs)).max(axis=2) < 1e-7
    assert (same | ~found).all()  # every branch py-opw finds is ours, in the same slot


def _with_q5(robot, q, paper5):
    o = robot.opw
    q = q.copy()
    q[:, 4] = (paper5 + o.offsets[4]) * o.signs[4]
    return q


@pytest.mark.parametrize("name", OPW_ROBOTS)
@pytest.mark.parametrize("paper5", [0.0, np.pi, -np.pi, 1e-13, np.pi - 1e-13])
def test_wrist_singularity(name, paper5, kernels):
    robot = rc.Robot.from_catalog(name)
    rng = np.random.default_rng(11)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (1000, 6))
    qs = _with_q5(robot, q, paper5)
    T = robot.fk(qs)
    sols = solve_all(robot, T)
    dp, dr = fk_errors(robot, sols, T)
    assert dp.max() < 1e-9 and dr.max() < 1e-9
    # same wrist centres with a regular wrist: exactly as many branches must exist
    regular = solve_all(robot, robot.fk(_with_q5(robot, q, 0.7)))
    assert (np.isfinite(sols).all(axis=2).sum(axis=1) == np.isfinite(regular).all(axis=2).sum(axis=1)).all()
    if abs(np.sin(paper5)) < 1e-12:  # documented split: paper theta4 = 0 in the unflipped slots
        o = robot.opw
        sol5 = wrapped(sols[:, :4, 4] * o.signs[4] - o.offsets[4])
        singular = np.isfinite(sol5) & (np.abs(np.sin(sol5)) < 1e-12)
        assert singular.any(axis=1).mean() > 0.95  # the original arm branch keeps theta5 = 0 / pi
        paper4 = wrapped(sols[:, :4, 3] * o.signs[3] - o.offsets[3])
        assert np.abs(paper4[singular]).max() < 1e-12


@pytest.mark.parametrize("name", ["abb_irb2600", "kuka_kr6_r700"])
def test_shoulder_singularity(name, kernels):
    robot = rc.Robot.from_catalog(name)
    o = robot.opw
    rng = np.random.default_rng(5)
    R = rotvec_to_matrix(rng.uniform(-2, 2, (200, 3)))
    z = o.c1 + rng.uniform(0.2, 0.6, 200) * (o.c2 + o.c3)
    C = np.stack([np.zeros(200), np.zeros(200), z], axis=1)  # wrist centre on the J1 axis
    flange = make_transform(R, C + o.c4 * R[:, :, 2])
    T = robot.base @ flange @ robot.tool
    sols = solve_all(robot, T)
    assert np.isfinite(sols).all(axis=2).sum(axis=1).min() >= 4
    dp, dr = fk_errors(robot, sols, T)
    assert dp.max() < 1e-9 and dr.max() < 1e-9


@pytest.mark.parametrize("name", OPW_ROBOTS)
def test_edge_of_reach(name, kernels):
    robot = rc.Robot.from_catalog(name)
    o = robot.opw
    rng = np.random.default_rng(2)
    q = rng.uniform(-1, 1, (500, 6))
    psi3 = np.arctan2(o.a2, o.c3)
    for phi in (0.0, np.pi):  # stretched and folded arm: both elbow branches coincide
        q[:, 2] = (phi - psi3 + o.offsets[2]) * o.signs[2]
        T = robot.fk(q)
        sols = solve_all(robot, T)
        # acos at +-1 turns 1e-16 of rounding into ~1e-8 rad (more where the wrist is near
        # singular too): recovery to 1e-4 rad, the FK check below is exact
        d = np.abs(wrapped(sols - q[:, None, :])).max(axis=2)
        if phi == 0.0:  # folded, the Puma's wrist centre lands on the J2 axis: FK check only
            assert (np.nanmin(np.where(np.isfinite(d), d, np.inf), axis=1) < 1e-4).all()
        assert (np.isfinite(sols).all(axis=2)[:, :4].sum(axis=1) >= 2).all()
        dp, dr = fk_errors(robot, sols, T)
        assert dp.max() < 1e-9 and dr.max() < 1e-9


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from([0.0, np.pi / 2, -np.pi, np.pi, 1e-9, -1e-9, 0.3, -2.5, 3.0]),
                min_size=6, max_size=6), st.integers(0, 3))
@pytest.mark.parametrize("choice", KERNELS)
def test_property_special_angles(choice, values, which):
    robot = rc.Robot.from_catalog(OPW_ROBOTS[which])
    q = np.clip(np.array(values)[None], robot.limits[:, 0], robot.limits[:, 1])
    T = robot.fk(q)
    with use_kernels(choice):
        sols = solve_all(robot, T)
    # the arm joints are recovered; at a singular wrist theta4/theta6 are split by convention
    arm = np.abs(wrapped(sols[:, :, :3] - q[:, None, :3])).max(axis=2)
    assert np.nanmin(arm) < 1e-6
    dp, dr = fk_errors(robot, sols, T)
    assert dp.max() < 1e-9 and dr.max() < 1e-9


def test_limits_and_turn_copies(kernels):
    robot = rc.Robot.from_catalog("abb_irb2600")  # J4, J6: +-400 deg
    rng = np.random.default_rng(1)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (300, 6))
    T = robot.fk(q)
    base = solve_all(robot, T)
    lim = solve_all(robot, T, limits=True)
    inside = ((base >= robot.limits[:, 0]) & (base <= robot.limits[:, 1])).all(axis=2)
    assert (np.isfinite(lim).all(axis=2) == inside).all()
    ext = solve_all(robot, T, extra_turns=True)
    ok = np.isfinite(ext).all(axis=2)
    assert ext.shape[1] > 8
    assert robot.within_limits(ext[ok]).all()
    # the original joints (outside [-pi, pi) for J4/J6 in general) are among the candidates
    d = np.abs(ext - q[:, None, :]).max(axis=2)
    assert (np.nanmin(np.where(ok, d, np.inf), axis=1) < 1e-7).all()
    dp, dr = fk_errors(robot, ext, T)
    assert dp.max() < 1e-9 and dr.max() < 1e-9
    # count: each in-limit branch has 1 + (copies of J4) * (copies of J6) combinations
    per_joint = [1 + (base[:, :, j] + 2 * np.pi <= robot.limits[j, 1]).astype(int)
                 + (base[:, :, j] - 2 * np.pi >= robot.limits[j, 0]) for j in (3, 5)]
    fixed = [0, 1, 2, 4]
    inside = ((base[..., fixed] >= robot.limits[fixed, 0]) & (base[..., fixed] <= robot.limits[fixed, 1]))
    expected = np.where(np.isfinite(base).all(axis=2) & inside.all(axis=2),
                        per_joint[0] * per_joint[1], 0).sum(axis=1)
    assert (ok.sum(axis=1) == expected).all()


def test_unreachable_is_nan(kernels):
    robot = rc.Robot.from_catalog("abb_irb2600")
    T = np.eye(4)[None].repeat(2, 0)
    T[0, :3, 3] = (5.0, 0, 0.5)  # 5 m away
    T[1, :3, 3] = (1.0, 0.2, 0.9)
    sols = solve_all(robot, T)
    assert np.isnan(sols[0]).all() and np.isfinite(sols[1]).all(axis=1).any()


def test_bad_input(kernels):
    robot = rc.Robot.from_catalog("abb_irb2600")
    T = robot.fk(np.zeros((1, 6)))
    bad = T.copy()
    bad[0, :3, :3] *= 1.01
    with pytest.raises(DataError, match="rigid"):
        solve_all(robot, bad)
    with pytest.raises(DataError, match="shape"):
        solve_all(robot, np.eye(3))
    with pytest.raises(ModelError, match="numeric"):
        solve_all(random_robot(np.random.default_rng(0)), T)
    with pytest.raises(ModelError, match="numeric"):
        solve_all(perturbed(robot, 0), T)


def test_numeric_random_robot_with_beta():
    rng = np.random.default_rng(4)
    robot = random_robot(rng)
    q = rng.uniform(-2, 2, (400, 6))
    T = robot.fk(q)
    res = rc.ik.solve(robot, T, q + rng.normal(0, 0.05, q.shape))
    assert res.converged.all()
    e = pose_error(T, robot.fk(res.joints))
    assert np.linalg.norm(e[:, :3], axis=1).max() <= 1e-10
    assert np.linalg.norm(e[:, 3:], axis=1).max() <= 1e-9


def test_numeric_seeded_from_nominal_same_branch():
    nominal = rc.Robot.from_catalog("abb_irb2600")
    robot = perturbed(nominal, 3)
    rng = np.random.default_rng(8)
    q = rng.uniform(nominal.limits[:, 0] * 0.7, nominal.limits[:, 1] * 0.7, (300, 6))
    o = nominal.opw
    phi = q[:, 2] * o.signs[2] - o.offsets[2] + np.arctan2(o.a2, o.c3)
    q = q[np.abs(np.sin(phi)) > 0.1]  # off the stretched arm, where branches of the two models differ
    T = robot.fk(q)
    for slot in (0, 5):
        res = rc.ik.solve(robot, T, branch=slot)
        exists = np.isfinite(res.seeds).all(axis=1)
        assert res.converged[exists].all() and not res.converged[~exists].any()
        # the solution stays in the seed's branch: close to it (a branch change moves joints by
        # ~pi; near the wrist singularity theta4/theta6 may swing by a few tenths)
        dev = np.abs(wrapped(res.joints - res.seeds))[exists].max(axis=1)
        assert np.median(dev) < 0.01 and dev.max() < 0.5


def test_numeric_reports_unreachable():
    robot = perturbed(rc.Robot.from_catalog("abb_irb2600"), 1)
    T = robot.fk(np.zeros((3, 6)))
    T[1, :3, 3] = (4.0, 0.0, 0.5)
    res = rc.ik.solve(robot, T, np.zeros((3, 6)))
    assert res.converged.tolist() == [True, False, True]
    assert res.failed.tolist() == [1]
    assert res.iterations > 100  # one run has at most max_iter = 100 steps: the retries' count too
    with pytest.raises(UnreachableError, match=r"\[1\]"):
        rc.ik.solve(robot, T, np.zeros((3, 6)), strict=True)
    with pytest.raises(DataError, match="seeds"):
        rc.ik.solve(robot, T, np.zeros((2, 6)))
    with pytest.raises(DataError, match="branch"):
        rc.ik.solve(robot, T, branch=9)


def test_numeric_ik_keeps_the_seed_turn():
    """On a joint with +-360 deg of travel, the solution stays on the seed's turn."""
    robot = rc.Robot.from_catalog("ur5")
    q_true = np.array([[0.3, -1.0, 1.2, -0.5, 0.8, 4.0]])  # q6 beyond pi: a second turn
    res = rc.ik.solve(robot, robot.fk(q_true), seeds=q_true + 0.01)
    assert res.converged.all()
    np.testing.assert_allclose(res.joints, q_true, atol=1e-8)


def _calibrated_cell(seed: int):
    nominal = rc.Robot.from_catalog("abb_irb2600")
    tool = make_transform(rotvec_to_matrix([0.1, -0.2, 0.3]), [0.05, 0.02, 0.2])
    return nominal.with_frames(tool=tool), perturbed(nominal, seed).with_frames(tool=tool)


def test_numeric_ik_reaches_every_reachable_target_in_its_branch():
    """1,000 random targets of a calibrated model away from singularities, each asked in the branch
    of the joints that reach it: every one converges, to those joints."""
    from robocal.ik.opw_ik import branch_slot
    from robocal.ik.singularity import singularity_distance

    nominal, calibrated = _calibrated_cell(11)
    rng = np.random.default_rng(11)
    q = rng.uniform(nominal.limits[:, 0], nominal.limits[:, 1], (3000, 6))
    q = q[singularity_distance(calibrated, q).sigma_rel > 0.02][:1000]
    assert len(q) == 1000
    T = calibrated.fk(q)
    slots = branch_slot(nominal.opw, q)
    found = np.zeros_like(q)
    for s in np.unique(slots):
        rows = slots == s
        res = rc.ik.solve(calibrated, T[rows], branch=int(s), nominal=nominal)
        assert res.converged.all()
        found[rows] = res.joints
    assert np.abs(wrapped(found - q)).max() < 1e-6


@pytest.mark.parametrize("elbow_deg", [0.5, 1.0, 1.5])
def test_numeric_ik_reaches_targets_next_to_the_stretched_elbow(elbow_deg):
    """Targets whose joints are within 1.5 deg of the calibrated arm's stretched elbow (where the
    nominal closed form may have no solution in the branch) are reached in the asked branch."""
    from robocal.ik.opw_ik import branch_slot

    nominal, calibrated = _calibrated_cell(3)
    o = nominal.opw
    rng = np.random.default_rng(4)
    q = rng.uniform(nominal.limits[:, 0] * 0.8, nominal.limits[:, 1] * 0.8, (60, 6))
    sign = rng.choice([-1.0, 1.0], 60)
    q[:, 2] = (sign * np.deg2rad(elbow_deg) - np.arctan2(o.a2, o.c3) + o.offsets[2]) * o.signs[2]
    inside = nominal.within_limits(q)
    q = q[inside]
    T = calibrated.fk(q)
    slots = branch_slot(nominal.opw, q)
    for s in np.unique(slots):
        rows = slots == s
        res = rc.ik.solve(calibrated, T[rows], branch=int(s), nominal=nominal)
        assert res.converged.all()
        assert (branch_slot(nominal.opw, res.joints) == s).all()


def test_path_candidates_of_a_calibrated_model_next_to_the_stretched_elbow():
    """plan_path's candidates of a calibrated model: numeric IK seeded in every branch, also where
    only the clamped nominal closed form seeds it (targets just beyond the nominal reach); every
    candidate reaches its pose in its own slot, and the slot of the joints that made the target is
    always among them."""
    from robocal.ik.opw_ik import branch_slot
    from robocal.ik.path import branch_candidates

    nominal, calibrated = _calibrated_cell(3)
    o = nominal.opw
    rng = np.random.default_rng(4)
    q = rng.uniform(nominal.limits[:, 0] * 0.8, nominal.limits[:, 1] * 0.8, (40, 6))
    elbow = rng.choice([-1.0, 1.0], 40) * np.deg2rad(rng.uniform(0, 0.5, 40))
    q[:, 2] = (elbow - np.arctan2(o.a2, o.c3) + o.offsets[2]) * o.signs[2]
    T = calibrated.fk(q)
    cand = branch_candidates(calibrated, T, nominal)
    found = np.isfinite(cand).all(axis=2)
    assert found[np.arange(len(q)), branch_slot(o, q)].all()
    n_idx, b_idx = np.nonzero(found)
    assert (branch_slot(o, cand[n_idx, b_idx]) == b_idx).all()
    e = pose_error(T[n_idx], calibrated.fk(cand[n_idx, b_idx]))
    assert np.linalg.norm(e[:, :3], axis=1).max() <= 1e-10


def test_a_joint_just_past_a_limit_is_not_turned_past_the_other():
    """Numeric IK moves a joint into its limits by a full turn only where that turn lands inside
    them: 0.01 deg past -170 deg stays there (it was returned as +189.99 deg, 20 deg past +170)."""
    robot = rc.Robot.from_catalog("fanuc_lrmate200id")
    q = np.deg2rad([[np.rad2deg(robot.limits[0, 0]) - 0.01, 10, 10, 0, -40, 0]])
    res = rc.ik.solve(robot, robot.fk(q), seeds=q)
    assert res.converged.all()
    np.testing.assert_allclose(res.joints, q, atol=1e-9)
