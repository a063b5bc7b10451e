"""Inverse kinematics of an arm on a linear track at given carriage positions e1.

The track is taken off first: with the carriage at e1 the arm's base is at
:func:`robocal.kinematics.cell.carriage_frames` (the track's direction, scale and mount applied), so a
world target T is the pose ``inv(carriage(e1)) @ T`` for the arm alone
(:func:`robocal.kinematics.cell.arm_model`). A nominal cell's arm keeps its OPW or UR form, so
:func:`solve_all` is the arm's closed form (all branches, vectorised over the targets, each with
its own e1); :func:`solve` reaches the targets on a calibrated cell by numeric IK over the arm's
joints with the track held at e1 (the program's own value), seeded by the nominal closed form in
the requested branch; :func:`plan` chooses the arm's branches along a path (seed 001's graph) at the
program's e1. Joints are ``(N, 7)``: e1 (m) then the arm's six (rad).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robocal.core.errors import DataError
from robocal.ik import closed_form
from robocal.ik.numeric import IKResult, nominal_seeds
from robocal.ik.numeric import solve as numeric_solve
from robocal.ik.opw_ik import check_poses
from robocal.ik.path import PathResult, plan_path
from robocal.kinematics.cell import arm_model, carriage_frames, is_track_cell
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform


def _check(robot: Robot, poses, e1) -> tuple[np.ndarray, np.ndarray]:
    """Checked targets ``(N, 4, 4)`` and carriage positions ``(N,)`` (m, inside the track limits)."""
    if not is_track_cell(robot):
        raise DataError(f"{robot.name} is not an arm on a track (joint 1 prismatic): use robocal.ik "
                        "closed_form or numeric")
    T = check_poses(poses)
    e1 = np.broadcast_to(np.asarray(e1, dtype=float), (len(T),)).copy()
    if not np.isfinite(e1).all():
        raise DataError("the carriage positions e1 must be finite (m)")
    lo, hi = robot.limits[0]
    out = np.flatnonzero((e1 < lo) | (e1 > hi))
    if out.size:
        raise DataError(f"e1 of target(s) {out[:10].tolist()} is outside the track's limits "
                        f"[{lo * 1e3:g}, {hi * 1e3:g}] mm (e.g. {e1[out[0]] * 1e3:.6g} mm)")
    return T, e1


def arm_targets(robot: Robot, poses, e1) -> tuple[Robot, np.ndarray]:
    """The arm of the cell (base frame identity) and the targets ``(N, 4, 4)`` in its base frame
    with the carriage at ``e1`` ``(N,)`` m."""
    T, e1 = _check(robot, poses, e1)
    return arm_model(robot), invert_transform(carriage_frames(robot, e1)) @ T


def solve_all(robot: Robot, poses, e1, **kwargs) -> np.ndarray:
    """Closed-form IK of a nominal cell: the arm's solutions ``(N, 8, 6)`` (rad; NaN where absent;
    keyword arguments as :func:`robocal.ik.closed_form.solve_all`) for world targets ``(N, 4, 4)``
    (m) with the carriage at ``e1`` ``(N,)`` m. DataError when the arm has no closed form (a
    calibrated cell: use :func:`solve`)."""
    arm, local = arm_targets(robot, poses, e1)
    if not closed_form.has_closed_form(arm):
        raise DataError(f"{robot.name}: the arm's chain has no OPW or UR form (a calibrated cell): use "
                        "robocal.ik.track.solve, seeded by the nominal cell")
    return closed_form.solve_all(arm, local, **kwargs)


def with_track(e1: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Cell joints ``(N, 7)``: e1 ``(N,)`` m then the arm's ``(N, 6)`` rad."""
    return np.concatenate([np.asarray(e1, float)[:, None], q], axis=1)


def solve(robot: Robot, poses, e1, *, nominal: Robot | None = None, branch: int | None = None,
          seeds=None, **kwargs) -> IKResult:
    """Joints ``(N, 7)`` putting the TCP of cell ``robot`` at world ``poses`` ``(N, 4, 4)`` with the
    track held at ``e1`` ``(N,)`` m: numeric IK over the arm's joints (:func:`robocal.ik.numeric.solve`,
    keyword arguments passed on), seeded by ``seeds`` ``(N, 6)`` (the arm's, rad) or by the
    closed form of the nominal cell (``nominal``, default the robot's own, with this robot's base
    and tool) in ``branch`` (None: per target the lowest slot inside the limits)."""
    T, e1 = _check(robot, poses, e1)
    if seeds is None:
        model = (robot.nominal_robot() if nominal is None else nominal).with_frames(base=robot.base,
                                                                                     tool=robot.tool)
        arm, local = arm_targets(model, T, e1)
        seeds = nominal_seeds(arm, local, branch)
    seeds = np.asarray(seeds, float)
    if seeds.shape != (len(T), 6):
        raise DataError(f"seeds of the arm must have shape ({len(T)}, 6), got {seeds.shape}")
    return numeric_solve(robot, T, with_track(e1, seeds), locked=[0], **kwargs)


def plan(robot: Robot, poses, e1, *, weights=None, start=None, nominal: Robot | None = None) -> PathResult:
    """The globally optimal arm joints along waypoints ``(M, 4, 4)`` (m) with the carriage at ``e1``
    ``(M,)`` m (:func:`robocal.ik.path.plan_path` on the arm, the track taken off); ``start`` and the
    joints of the result are the cell's ``(7,)`` / ``(M, 7)`` (e1 first, as given); ``weights``
    are the arm's ``(6,)``; ``nominal``: the controller's cell model (its arm seeds a calibrated one)."""
    T, e1 = _check(robot, poses, e1)
    arm, local = arm_targets(robot, T, e1)
    arm_nominal = None if nominal is None else arm_model(nominal)
    arm_start = None
    if start is not None:
        arm_start = np.asarray(start, dtype=float).reshape(-1)
        if arm_start.shape != (robot.n_joints,):
            raise DataError(f"start must be the cell's {robot.n_joints} joints (e1 first), got "
                            f"{arm_start.size}")
        arm_start = arm_start[1:]
    res = plan_path(arm, local, weights=weights, start=arm_start, nominal=arm_nominal)
    return replace(res, joints=with_track(e1, res.joints), greedy_joints=with_track(e1, res.greedy_joints),
                   joint_specs=robot.joints)
