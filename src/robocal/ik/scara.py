"""Inverse kinematics of a SCARA (RRPR: shoulder, elbow, quill, quill rotation; all axes parallel).

A SCARA reaches a position and a turn about its axes (4 degrees of freedom): it cannot tilt its
flange. Two branches, the arm's hands, in a fixed slot order: slot 0 the elbow angle (the turn
from the upper arm to the forearm about the robot's axis direction) positive, slot 1 negative.

- :func:`seed_branches`: the planar two-link closed form (``L1`` = the distance between axes 1 and
  2, ``L2`` = between axes 2 and 4, the joint zeros' offsets taken from the model at q = 0), for
  any SCARA chain, unverified: seeds.
- :func:`refine`: Newton (steps clipped to :data:`_MAX_STEP`) on the 4 task residuals (position,
  turn about the axis) of the model itself, a calibrated one included (its axes a little tilted:
  the tilt of the flange is then what the calibrated robot has at that position, not a task).
- :func:`chunk_solver`: the verified closed form of a nominal SCARA (the form
  :mod:`robocal.ik.closed_form` registers): each branch refined and kept where the model's pose
  equals the target within ``tol`` (a target tilted off the axis has no solution).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robocal.kinematics.convert import PARALLEL_TOL
from robocal.kinematics.fk import chain_frames
from robocal.kinematics.model import Robot

BRANCHES = 2
_ITERATIONS = 30
_MAX_STEP = 0.2  # rad (m on the quill): the longest step one iteration takes
_SINGULAR_FLOOR = 1e-12  # added to the task Jacobian's diagonal (a stretched arm's elbow)
_CHUNK = 20_000
_SEED_MARGIN = 1e-9  # cos(elbow) clamped this far inside [-1, 1] (a target a hair out of reach)
TASK_TOL = (1e-10, 1e-9)  # converged: position error (m) and turn error about the axis (rad)


def _frames(robot: Robot, q: np.ndarray) -> np.ndarray:
    """World frames {0}..{n} ``(N, n + 1, 4, 4)`` of joints ``q`` ``(N, n)``."""
    return chain_frames(robot.links, robot.base, robot.tool, q, frames=True, prismatic=robot.prismatic)[1]


def _frame_axes(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Joint axis directions ``(N, n, 3)`` (world) at joints ``q`` ``(N, n)``."""
    return _frames(robot, q)[:, 1:, :3, 2]


def is_scara(robot: Robot) -> bool:
    """Whether ``robot``'s own chain is a nominal SCARA: 4 joints, the third prismatic, the others
    revolute, every joint axis parallel to the first (within
    `robocal.kinematics.convert.PARALLEL_TOL`, |sin| of their angle)."""
    if robot.n_joints != 4 or list(robot.prismatic) != [False, False, True, False]:
        return False
    z = _frame_axes(robot, np.zeros((1, 4)))[0]
    return bool(np.all(np.linalg.norm(np.cross(z, z[0]), axis=1) <= PARALLEL_TOL))


def is_scara_arm(robot: Robot) -> bool:
    """Whether ``robot`` is a SCARA or a calibrated model of one (its nominal model is)."""
    return robot.n_joints == 4 and is_scara(robot.nominal_robot())


def first_axis(robot: Robot) -> np.ndarray:
    """Joint 1's axis direction ``(3,)`` (world, unit) of a 4-joint ``robot`` at q = 0."""
    return _frames(robot, np.zeros((1, 4)))[0][1, :3, 2]


def _geometry(robot: Robot) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float, float, np.ndarray]:
    """``(origin, axis, e, L1, L2, elbow0, F)``: axis 1's point and direction (world), the unit
    direction ``e`` of the upper arm at q = 0 (across the axis), the lengths axis 1 -> axis 2 and
    axis 2 -> axis 4 (m), the elbow's angle at q = 0 (rad, about the axis, from the upper arm to the
    forearm) and the world frames ``(5, 4, 4)`` at q = 0."""
    F = _frames(robot, np.zeros((1, 4)))[0]
    axis = F[1, :3, 2]
    o1, o2, o4 = F[1, :3, 3], F[2, :3, 3], F[4, :3, 3]
    flat = np.eye(3) - np.outer(axis, axis)
    u, v = flat @ (o2 - o1), flat @ (o4 - o2)
    L1, L2 = float(np.linalg.norm(u)), float(np.linalg.norm(v))
    elbow0 = float(np.arctan2(np.cross(u, v) @ axis, u @ v))
    return o1, axis, u / L1, L1, L2, elbow0, F


def seed_branches(robot: Robot, T: np.ndarray) -> np.ndarray:
    """Unverified seeds ``(N, 2, 4)`` (module docstring) for world TCP poses ``T`` ``(N, 4, 4)``."""
    o1, axis, e, L1, L2, elbow0, F = _geometry(robot)
    N = T.shape[0]
    # the flange frame {4} on axis 4: the target's, from the TCP pose (the tool is fixed to frame 4)
    post = np.linalg.inv(F[4]) @ robot.fk(np.zeros((1, 4)))[0]  # frame {4} -> TCP at q = 0
    W = T @ np.linalg.inv(post)
    d = W[:, :3, 3] - o1
    height = d @ axis
    d = d - height[:, None] * axis
    f = np.cross(axis, e)
    x, y = d @ e, d @ f
    c = np.clip((x**2 + y**2 - L1**2 - L2**2) / (2 * L1 * L2), -1 + _SEED_MARGIN, 1 - _SEED_MARGIN)
    q = np.zeros((N, BRANCHES, 4))
    s1, s2 = np.sign(F[1:3, :3, 2] @ axis)  # joints 1 and 2 turn about +axis or -axis
    for b, sign in enumerate((1.0, -1.0)):
        elbow = sign * np.arccos(c)
        shoulder = np.arctan2(y, x) - np.arctan2(L2 * np.sin(elbow), L1 + L2 * np.cos(elbow))
        q[:, b, 0] = s1 * shoulder
        q[:, b, 1] = s2 * (elbow - elbow0)
    # the quill: the height of frame {4} above its height at q = 0 along the axis
    q[:, :, 2] = (height - (F[4, :3, 3] - o1) @ axis)[:, None]
    q[:, :, 2] *= np.sign(F[3, :3, 2] @ axis)  # the quill's own axis may point down
    # the last joint: the turn that brings frame {4}'s x to the target's, about the axis
    q = _turn_last(robot, W, q, axis)
    q[..., [0, 1, 3]] = (q[..., [0, 1, 3]] + np.pi) % (2 * np.pi) - np.pi
    return q


def _turn_last(robot: Robot, W: np.ndarray, q: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """``q`` with joint 4 set so that frame {4}'s x axis turns onto ``W``'s (about ``axis``)."""
    N, B, n = q.shape
    F = _frames(robot, q.reshape(-1, n))
    x_have = F[:, 4, :3, 0].reshape(N, B, 3)
    x_want = np.repeat(W[:, None, :3, 0], B, axis=1)
    s = np.sign(F[0, 4, :3, 2] @ axis)  # joint 4 turns about +axis or -axis
    turn = np.arctan2(np.cross(x_have, x_want) @ axis, np.einsum("nbi,nbi->nb", x_have, x_want))
    q = q.copy()
    q[..., 3] += s * turn
    return q


def task_error(robot: Robot, T: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``(N, 4)`` task residuals of joints ``q`` ``(N, 4)`` against world TCP poses ``T``: the
    position error (m, world) and the turn (rad) about the robot's axis from the model's TCP x axis
    to the target's."""
    return _task_error(robot, T, q)[0]


def _task_error(robot: Robot, T: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`task_error` and joint 1's axis ``(N, 3)`` (world) at ``q`` it turns about (for the
    Newton step, which needs the same axis)."""
    have = robot.fk(q)
    axis = _frame_axes(robot, q)[:, 0]
    xh, xw = have[:, :3, 0], T[:, :3, 0]
    turn = np.arctan2(np.einsum("ni,ni->n", np.cross(xh, xw), axis), np.einsum("ni,ni->n", xh, xw))
    return np.hstack([T[:, :3, 3] - have[:, :3, 3], turn[:, None]]), axis


def refine(robot: Robot, T: np.ndarray, q0: np.ndarray, iterations: int = _ITERATIONS
           ) -> tuple[np.ndarray, np.ndarray]:
    """Newton on the 4 task residuals (:func:`task_error`) from ``q0`` ``(N, 4)``, batched; returns
    the joints and their final residuals ``(N, 4)``. The task Jacobian is the model's pose Jacobian
    (position rows, and the rotation rows projected on the robot's axis)."""
    q = np.asarray(q0, float).copy()
    for _ in range(iterations):
        r, axis = _task_error(robot, T, q)  # the axis at q once: the residual's and the step's
        if not np.isfinite(r).all() or (np.linalg.norm(r[:, :3], axis=1) <= TASK_TOL[0] / 10).all() \
                and (np.abs(r[:, 3]) <= TASK_TOL[1] / 10).all():
            break
        J = robot.jacobian(q, robot.joint_params, kind="pose")  # (N, 6, 4): position, rotation
        A = np.concatenate([J[:, :3], np.einsum("ni,nij->nj", axis, J[:, 3:])[:, None]], axis=1)
        step = np.linalg.solve(A + _SINGULAR_FLOOR * np.eye(4), r[:, :, None])[..., 0]
        q = q + step * np.minimum(1.0, _MAX_STEP / np.maximum(np.abs(step).max(axis=1), 1e-300))[:, None]
    return q, task_error(robot, T, q)


def converged(err: np.ndarray) -> np.ndarray:
    """``(N,)``: task residuals ``(N, 4)`` within :data:`TASK_TOL`."""
    return (np.linalg.norm(err[:, :3], axis=1) <= TASK_TOL[0]) & (np.abs(err[:, 3]) <= TASK_TOL[1])


def chunk_solver(robot: Robot, tol: float) -> tuple[Callable[[np.ndarray], np.ndarray], int]:
    """The verified closed form of a nominal SCARA (module docstring) and its chunk size."""

    def solve(T: np.ndarray) -> np.ndarray:
        seeds = seed_branches(robot, T)
        N = T.shape[0]
        want = np.repeat(T, BRANCHES, axis=0)
        q, _ = refine(robot, want, seeds.reshape(-1, 4))
        have = robot.fk(q)
        ok = (np.abs(have - want).max(axis=(1, 2)) <= tol) & np.isfinite(q).all(axis=1)
        q[~ok] = np.nan
        q[:, [0, 1, 3]] = (q[:, [0, 1, 3]] + np.pi) % (2 * np.pi) - np.pi
        return q.reshape(N, BRANCHES, 4)

    return solve, _CHUNK


def branch_slot(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Slot ``(...,)`` of joints ``(..., 4)`` on nominal SCARA ``robot``: 0 where the elbow angle
    (upper arm to forearm, about the axis) is positive, 1 where it is negative."""
    *_, elbow0, _ = _geometry(robot)
    elbow = (np.asarray(q)[..., 1] + elbow0 + np.pi) % (2 * np.pi) - np.pi
    return (elbow < 0).astype(int)
