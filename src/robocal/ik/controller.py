"""The IK solution a robot controller takes for Cartesian targets without configuration data.

A UR controller (movel / movej to a pose in URScript), and any controller given a target with no
configuration, takes the inverse-kinematics solution nearest the joints it is at. This module
emulates that on the controller's nominal model: per target, in program order, every closed-form
solution (:func:`robocal.ik.solve_all`, OPW or UR form) inside the joint limits, with the +-2 pi
copies of joints that travel more than a turn, is a candidate; the one nearest the previous
target's joints (sum of squared joint differences, rad^2) is taken. "Wrap-aware" here means what
the joints are: a joint at 350 deg is 20 deg from one at -350 deg only when both lie in its
limits; the copies a turn apart are separate candidates, as on the robot.

A target whose nearest solution still moves some joint by more than ``jump_deg`` from the
previous joints is reported (``jumps``): the controller reaches it by a large joint motion, and
a small change of the previous joints can make it take another solution.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.core.errors import DataError
from robocal.ik.closed_form import branch_slot, seed_model
from robocal.ik.numeric import seeded_branches, solve
from robocal.ik.opw_ik import check_poses
from robocal.kinematics.model import Robot

JUMP_DEG = 60.0  # a joint moving more than this from the previous target's joints is reported


@dataclass(frozen=True)
class ControllerChoice:
    """``joints`` ``(N, n)`` rad (NaN where no solution inside the limits), ``slots`` ``(N,)`` the
    closed-form slot taken (-1: none), ``move`` ``(N,)`` rad the largest joint move from the
    previous joints, ``unreachable`` and ``jumps`` indices, ``candidates`` ``(N,)`` how many
    solutions each target had."""

    joints: np.ndarray
    slots: np.ndarray
    move: np.ndarray
    unreachable: np.ndarray
    jumps: np.ndarray
    candidates: np.ndarray


def nearest_solutions(robot: Robot, poses, start, anchors=None,
                      jump_deg: float = JUMP_DEG) -> ControllerChoice:
    """The controller's choice for world TCP poses ``(N, 4, 4)`` (m) of ``robot`` (the controller's
    model; it must have a closed form, or a seed model's refined numerically:
    :func:`robocal.ik.numeric.seeded_branches`) visited in order from joints ``start`` ``(n,)`` (rad).

    ``anchors`` ``(N, n)`` (rad, NaN rows: none): joints the robot is known to be at right before
    target i (a joint move, or a qnear the program gives), which replace the previous target's.
    A target without a solution inside the limits is NaN and listed in ``unreachable``; the next
    one is chosen from the last joints the robot had."""
    T = check_poses(poses)
    N, n = T.shape[0], robot.n_joints
    start = np.asarray(start, dtype=float).reshape(-1)
    if start.shape != (n,) or not np.isfinite(start).all():
        raise DataError(f"start joints must be {n} finite values (rad), got {start.tolist()}")
    anchors = np.full((N, n), np.nan) if anchors is None else np.asarray(anchors, dtype=float)
    if anchors.shape != (N, n):
        raise DataError(f"anchors must have shape ({N}, {n}), got {anchors.shape}")
    copies, valid = _joint_copies(robot, seeded_branches(robot, T))
    joints = np.full((N, n), np.nan)
    move = np.full(N, np.nan)
    taken = np.full(N, -1)
    prev = start
    cols = np.arange(n)
    for i in range(N):  # sequential by nature: each choice depends on the previous one
        if np.isfinite(anchors[i]).all():
            prev = anchors[i]
        # the distance is a sum over joints: per branch, each joint's nearest copy inside its limits
        d = np.where(valid[i], (copies[i] - prev[None, :, None]) ** 2, np.inf)  # (B, n, C)
        near = np.argmin(d, axis=2)
        cost = np.take_along_axis(d, near[:, :, None], axis=2)[:, :, 0].sum(axis=1)
        if not np.isfinite(cost).any():
            continue
        k = int(np.argmin(cost))
        joints[i], taken[i] = copies[i, k, cols, near[k]], k
        move[i] = np.abs(joints[i] - prev).max()
        prev = joints[i]
    ok = taken >= 0
    slots = np.full(N, -1)
    if ok.any():
        slots[ok] = branch_slot(seed_model(robot), joints[ok])
    return ControllerChoice(joints=joints, slots=slots, move=move, unreachable=np.flatnonzero(~ok),
                            jumps=np.flatnonzero(ok & (move > np.deg2rad(jump_deg))),
                            candidates=valid.sum(axis=3).prod(axis=2).sum(axis=1))


def _joint_copies(robot: Robot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per branch and joint, the solution's value and its +-2 pi copies: ``(N, B, n, C)`` rad and
    whether each lies inside the joint's limits (a branch without a solution: none does). The
    candidates of :func:`robocal.ik.closed_form.turn_copies` are every combination of them."""
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    kmin = np.floor((lo - np.pi) / (2 * np.pi)).astype(int) + 1  # q in [-pi, pi): the copies that can fit
    kmax = np.ceil((hi + np.pi) / (2 * np.pi)).astype(int) - 1
    k = np.arange(kmin.min(), kmax.max() + 1)
    copies = q[..., None] + 2 * np.pi * k  # (N, B, n, C)
    valid = (np.isfinite(copies) & (copies >= lo[:, None]) & (copies <= hi[:, None])
             & np.isfinite(q).all(axis=2)[:, :, None, None])
    return copies, valid


def followed_numerically(robot: Robot, poses, start) -> np.ndarray:
    """Joints ``(N, n)`` (rad) of ``robot`` reaching world TCP poses ``(N, 4, 4)`` (m) in order, each
    solved numerically (:func:`robocal.ik.numeric.solve`) from the joints of the previous target
    reached, the first from ``start`` ``(n,)`` rad: the nearest solution a controller moves to, for
    a chain without a closed form (a 5-axis or a redundant 7-axis arm), where
    :func:`nearest_solutions` has no branches to choose from. A pose not reached is a NaN row; the
    next one starts from the last joints reached."""
    T = check_poses(poses)
    n = robot.n_joints
    prev = np.asarray(start, dtype=float).reshape(-1)
    if prev.shape != (n,) or not np.isfinite(prev).all():
        raise DataError(f"start joints must be {n} finite values (rad), got {prev.tolist()}")
    joints = np.full((T.shape[0], n), np.nan)
    for i in range(T.shape[0]):  # sequential by nature: each seed is the previous target's joints
        res = solve(robot, T[i:i + 1], prev[None])
        if res.converged[0]:
            joints[i] = prev = res.joints[0]
    return joints
