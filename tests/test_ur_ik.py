"""Closed-form UR IK (three parallel axes, offset wrist): every UR of the catalog against the
independent C++ solver ur-analytic-ik (FK identical, every solution FK-exact, none of the peer's
missed, the original joints recovered), the singular configurations, UR-form robots of any
layout, detection and the numeric IK of calibrated URs seeded from these branches."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from robots import KERNELS, random_frame, wrapped
from test_ik import fk_errors, recovered

import robocal as rc
from robocal.core.errors import ModelError
from robocal.data.simulate import perturbed
from robocal.ik import solve_all
from robocal.ik.closed_form import branch_slot
from robocal.ik.singularity import singularity_distance
from robocal.kinematics.catalog import catalog_names
from robocal.kinematics.kernels import use_kernels

UR_ROBOTS = [n for n in catalog_names() if rc.Robot.from_catalog(n).has_ur_form]
PEER_N = 20_000  # random joint vectors per UR against the peer
EXACT = 1e-9  # m / rad: every returned solution's FK error
SAME = 1e-7  # rad: two solutions are the same


def test_every_catalog_ur_has_the_form():
    assert {"ur3", "ur3e", "ur5", "ur5e", "ur10", "ur10e", "ur16e", "ur20", "ur30"} <= set(UR_ROBOTS)
    for name in catalog_names():
        robot = rc.Robot.from_catalog(name)
        assert not (robot.has_ur_form and robot.has_opw_form), name


@pytest.mark.slow
@pytest.mark.parametrize("name", UR_ROBOTS)
def test_against_ur_analytic_ik(name):
    peer = pytest.importorskip("ur_analytic_ik", reason="ur-analytic-ik (test extra) not installed")
    model = getattr(peer, name)
    robot = rc.Robot.from_catalog(name)
    rng = np.random.default_rng(21)
    q = rng.uniform(-np.pi, np.pi, (PEER_N, 6))
    T = robot.fk(q)
    theirs_fk = np.array([model.forward_kinematics(*row) for row in q])
    assert np.abs(T - theirs_fk).max() <= 1e-12  # the same kinematics, tool0 in base
    ours = solve_all(robot, T)
    assert recovered(ours, q).all()
    dp, dr = fk_errors(robot, ours, T)
    assert dp.max() <= EXACT and dr.max() <= EXACT
    sols = [model.inverse_kinematics(T[i]) for i in range(PEER_N)]
    owner = np.repeat(np.arange(PEER_N), [len(s) for s in sols])
    theirs = np.array([row for s in sols for row in s]).reshape(-1, 6)
    # a peer row that is not a solution (its own rounding) cannot be missed
    real = np.abs(robot.fk(theirs) - T[owner]).max(axis=(1, 2)) <= EXACT
    d = np.abs(wrapped(ours[owner] - theirs[:, None, :])).max(axis=2)
    missed = (~(np.nanmin(np.where(np.isfinite(d), d, np.inf), axis=1) < SAME) & real).sum()
    assert real.mean() > 0.99
    assert missed == 0


def _ur_like(rng, sg3: float = 1.0, sg4: float = 1.0) -> rc.Robot:
    """A random UR-form robot: any alpha1/a1/beta1, offsets, d's, a2, a5, alpha signs, base, tool."""
    s = lambda: rng.choice([-1.0, 1.0])  # noqa: E731
    alpha = [rng.uniform(-np.pi, np.pi), s() * np.pi / 2, 0.0 if sg3 > 0 else np.pi,
             0.0 if sg4 > 0 else np.pi, s() * np.pi / 2, s() * np.pi / 2]
    a = [rng.uniform(-0.2, 0.2), rng.uniform(-0.1, 0.1), rng.uniform(0.2, 0.6) * s(),
         rng.uniform(0.2, 0.6) * s(), rng.uniform(-0.05, 0.05), 0.0]
    beta = [rng.uniform(-0.3, 0.3), 0, 0, 0, 0, 0]
    return rc.Robot(alpha=alpha, a=a, beta=beta, theta=rng.uniform(-np.pi, np.pi, 6),
                    d=rng.uniform(-0.2, 0.2, 6), base=random_frame(rng, 1.0), tool=random_frame(rng, 0.2))


@pytest.mark.parametrize("sg3,sg4", [(1, 1), (-1, 1), (1, -1), (-1, -1)])
def test_any_ur_form_layout(sg3, sg4, kernels):
    rng = np.random.default_rng(int(5 + 3 * sg3 + sg4))
    for _ in range(5):
        robot = _ur_like(rng, sg3, sg4)
        assert robot.has_ur_form and not robot.has_opw_form
        q = rng.uniform(-np.pi, np.pi, (1000, 6))
        T = robot.fk(q)
        sols = solve_all(robot, T)
        assert recovered(sols, q).all()
        dp, dr = fk_errors(robot, sols, T)
        assert dp.max() <= EXACT and dr.max() <= EXACT
        # each solution sits in the slot its joints name
        ok = np.isfinite(sols).all(axis=2)
        slots = np.broadcast_to(np.arange(8), ok.shape)
        assert (branch_slot(robot, sols[ok]) == slots[ok]).mean() > 0.999


def _flip(q, j, value, theta):
    q = q.copy()
    q[:, j] = value - theta[j]
    return q


@pytest.mark.parametrize("name", ["ur5", "ur10e", "ur20"])
@pytest.mark.parametrize("chi", [0.0, np.pi, -np.pi, 1e-13, np.pi - 1e-13])
def test_wrist_singularity(name, chi, kernels):
    """Axes 4 and 6 parallel (then 2, 3, 4 and 6 all are): a continuum over q2, q3, q4, q6; a valid
    member is returned, never NaN; q1 and q5 are determined and recovered."""
    robot = rc.Robot.from_catalog(name)
    rng = np.random.default_rng(11)
    q = _flip(rng.uniform(-np.pi, np.pi, (1000, 6)), 4, chi, robot.theta)
    T = robot.fk(q)
    sols = solve_all(robot, T)
    dp, dr = fk_errors(robot, sols, T)
    assert dp.max() <= EXACT and dr.max() <= EXACT
    fixed = np.abs(wrapped(sols[:, :, [0, 4]] - q[:, None, [0, 4]])).max(axis=2)
    assert (np.nanmin(np.where(np.isfinite(fixed), fixed, np.inf), axis=1) < 1e-6).all()
    assert (np.isfinite(sols).all(axis=2).sum(axis=1) >= 2).all()


@pytest.mark.parametrize("name", ["ur5", "ur16e"])
@pytest.mark.parametrize("elbow", [0.0, np.pi])
def test_elbow_singularity(name, elbow, kernels):
    """Arm stretched (q3 = 0) or folded (q3 = pi): both elbow solutions coincide, none is lost."""
    robot = rc.Robot.from_catalog(name)
    rng = np.random.default_rng(4)
    q = _flip(rng.uniform(-np.pi, np.pi, (1000, 6)), 2, elbow, robot.theta)
    T = robot.fk(q)
    sols = solve_all(robot, T)
    dp, dr = fk_errors(robot, sols, T)
    assert dp.max() <= EXACT and dr.max() <= EXACT
    d = np.abs(wrapped(sols - q[:, None, :])).max(axis=2)
    assert (np.nanmin(np.where(np.isfinite(d), d, np.inf), axis=1) < 1e-4).all()  # acos at +-1


@pytest.mark.parametrize("name", ["ur5", "ur30"])
def test_shoulder_singularity(name, kernels):
    """The wrist point (axes 5 and 6 meet) on the cylinder r = |c2| about axis 1: both shoulder
    solutions coincide."""
    robot = rc.Robot.from_catalog(name)
    form = robot.ur_form
    rng = np.random.default_rng(6)
    q = rng.uniform(-np.pi, np.pi, (4000, 6))
    T = robot.fk(q)
    # move each pose so that its wrist point lies on the cylinder, keeping its orientation
    P = T[:, :3, 3] - form.d6 * T[:, :3, 2]
    r = np.hypot(P[:, 0], P[:, 1])
    scale = abs(form.c2) / r
    moved = T.copy()
    moved[:, :2, 3] += (scale[:, None] - 1.0) * P[:, :2]
    sols = solve_all(robot, moved)
    ok = np.isfinite(sols).all(axis=2)
    assert ok.any(axis=1).mean() > 0.5  # on the cylinder the arm plane passes through axis 1
    dp, dr = fk_errors(robot, sols, moved)
    assert dp.max() <= EXACT and dr.max() <= EXACT
    # where one shoulder solution exists the other does too (they coincide)
    assert (ok[:, [0, 1, 4, 5]].any(axis=1) == ok[:, [2, 3, 6, 7]].any(axis=1)).mean() > 0.99


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from([0.0, np.pi / 2, -np.pi, np.pi, 1e-9, -1e-9, 0.3, -2.5, 3.0]),
                min_size=6, max_size=6), st.sampled_from(["ur5", "ur3e", "ur20"]))
@pytest.mark.parametrize("choice", KERNELS)
def test_property_special_angles(choice, values, name):
    robot = rc.Robot.from_catalog(name)
    q = np.array(values)[None]
    T = robot.fk(q)
    with use_kernels(choice):
        sols = solve_all(robot, T)
    fixed = np.abs(wrapped(sols[:, :, [0, 4]] - q[:, None, [0, 4]])).max(axis=2)  # see the wrist test
    assert np.nanmin(fixed) < 1e-6
    dp, dr = fk_errors(robot, sols, T)
    assert dp.max() <= EXACT and dr.max() <= EXACT


def test_calibrated_ur_keeps_numeric_ik_seeded_from_its_branches():
    robot = rc.Robot.from_catalog("ur5e")
    cal = perturbed(robot, 3)
    assert not cal.has_ur_form and cal.nominal_robot().has_ur_form
    with pytest.raises(ModelError, match="numeric"):
        solve_all(cal, robot.fk(np.zeros(6)))
    rng = np.random.default_rng(8)
    q = rng.uniform(-np.pi, np.pi, (600, 6))
    far = singularity_distance(robot, q)  # branches are well apart only away from the singularities
    q = q[(far.shoulder_mm > 50) & (far.elbow_deg > 10) & (far.wrist_deg > 10)]
    T = cal.fk(q)
    slot = branch_slot(robot, q)
    for b in range(8):
        rows = np.flatnonzero(slot == b)
        res = rc.ik.solve(cal, T[rows], branch=b)
        assert res.converged.all(), b
        np.testing.assert_allclose(wrapped(res.joints - q[rows]), 0.0, atol=1e-7)
