"""Closed-form inverse kinematics of every form robocal solves: OPW arms (spherical wrist,
:mod:`robocal.ik.opw_ik`) and UR arms (three parallel axes, offset wrist, :mod:`robocal.ik.ur_ik`).

The form is the robot's own, recognised from its chain's geometry: an OPW arm (:attr:`Robot.opw_model`:
the set the model carries, or one derived from its joint lines whatever the chain was written in), or
the UR structure of its links (:attr:`Robot.has_ur_form`). Both
give up to 8 solutions in the same slot order, ``s = 4 * wrist_flip + 2 * shoulder + elbow``,
each verified by ``robot.fk``. A calibrated model has neither: numeric IK
(:func:`robocal.ik.numeric.solve`) seeds it from its nominal model's closed form
(:func:`seed_branches`, :func:`branch_slot` on the nominal model).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np

import robocal.ik.opw_ik as opw_ik
import robocal.ik.scara as scara_ik
import robocal.ik.ur_ik as ur_ik
from robocal.core.errors import ModelError
from robocal.ik.opw_ik import SEED_MARGIN, TOL, check_poses
from robocal.kinematics.model import Robot
from robocal.kinematics.model_file import LINK_FIELDS
from robocal.kinematics.opw_geometry import opw_model
from robocal.kinematics.ur import nearest_ur_links


def has_closed_form(robot: Robot) -> bool:
    """Whether closed-form IK applies to this robot's own chain (OPW, UR or SCARA form)."""
    return robot.opw_model is not None or robot.has_ur_form or scara_ik.is_scara(robot)


def seed_model(model: Robot) -> Robot:
    """The model whose closed form seeds numeric IK on ``model``: ``model`` itself when it has a
    closed form; for a calibrated UR chain without one (e.g. a factory calibration imported with
    ``robocal import-calibration``, beta on its parallel axes) the nearest UR-form chain
    (:func:`robocal.kinematics.ur.nearest_ur_links`, same base and tool); for a chain a little off
    the OPW form (a URDF with rounded angles) the nearest OPW arm
    (:func:`robocal.kinematics.opw_geometry.opw_model` with ``seed=True``); else ``model``."""
    if has_closed_form(model) or model.n_joints != 6:
        return model
    links = nearest_ur_links(*model.links)
    if links is None:
        return opw_model(model, seed=True) or model
    return replace(model, joint_errors=None, **dict(zip(LINK_FIELDS, links, strict=True)))


def _module(robot: Robot):
    """The solver module of the robot's own form; ModelError naming why there is none."""
    if robot.opw_model is not None:
        return opw_ik
    if robot.has_ur_form:
        return ur_ik
    if scara_ik.is_scara(robot):
        return scara_ik
    if robot.opw is not None:
        opw_ik.opw_form(robot)  # raises its message (a calibrated model of an OPW arm)
    raise ModelError(
        f"robot {robot.name!r} has no closed form (neither an OPW arm with a spherical wrist nor a UR "
        "arm with three parallel axes and an offset wrist, or a calibrated model whose chain left its "
        "nominal form), so closed-form inverse kinematics is not available; use the numeric solver "
        "rc.ik.solve(robot, poses, seeds), which is seeded by the nominal closed form where there is one")


def solve_branches(robot: Robot, T: np.ndarray, tol: float = TOL, threads: int | None = None) -> np.ndarray:
    """All verified solutions ``(N, B, n)`` for checked world poses ``T`` (no limit handling): B = 8
    slots of a 6-axis arm, 2 of a SCARA (:mod:`robocal.ik.scara`).

    Raises ModelError when the robot's chain has no closed form (:func:`has_closed_form`)."""
    module = _module(robot)
    solve, size = module.chunk_solver(robot, tol)
    N = T.shape[0]
    parts = [slice(s, min(s + size, N)) for s in range(0, N, size)]
    out = np.empty((N, getattr(module, "BRANCHES", 8), robot.n_joints))
    workers = threads or min(os.cpu_count() or 1, 8)

    def run(part: slice) -> None:
        out[part] = solve(T[part])

    if workers > 1 and len(parts) > 1:
        with ThreadPoolExecutor(workers) as pool:
            list(pool.map(run, parts))
    else:
        for part in parts:
            run(part)
    return out


def seed_branches(robot: Robot, T: np.ndarray) -> np.ndarray:
    """Seeds ``(N, 8, 6)`` for numeric IK in every slot: the closed form of the robot's form with
    out-of-reach arguments clamped, not verified (a pose a little beyond the nominal reach, which
    a calibrated robot may still reach, gets a seed in each slot, off the stretched arm)."""
    module = _module(robot)
    if module is opw_ik:
        return opw_ik.seed_branches(robot, T)
    if module is scara_ik:
        return scara_ik.seed_branches(robot, T)
    return ur_ik.seed_branches(robot, T, SEED_MARGIN)


def branch_slot(nominal: Robot, q: np.ndarray) -> np.ndarray:
    """Closed-form slot ``(...,)`` of joints ``(..., 6)`` on ``nominal`` (a nominal model: its OPW
    set, else the UR form of its chain); a calibrated robot's slots are its nominal model's."""
    if nominal.opw is not None:
        return opw_ik.branch_slot(nominal.opw, q)
    if nominal.opw_model is not None:
        return opw_ik.branch_slot(nominal.opw_model.opw, q)
    if scara_ik.is_scara(nominal):
        return scara_ik.branch_slot(nominal, q)
    shoulder, elbow, flip = ur_ik.branch_bits(nominal, q)
    return 4 * flip.astype(int) + 2 * shoulder.astype(int) + elbow.astype(int)


def branch_model(robot: Robot, nominal: Robot | None = None) -> Robot | None:
    """The nominal model whose closed form names the branches of ``robot``'s joints (``nominal``,
    default the robot's own nominal model), or None when it has no closed form."""
    model = seed_model(robot.nominal_robot() if nominal is None else nominal)
    if model.n_joints != 6 or robot.n_joints != 6:
        return None
    return model if model.opw is not None or model.opw_model is not None or model.has_ur_form else None


def turn_copies(robot: Robot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Candidates inside the joint limits, including the +-2 pi copies of each solution.

    q ``(N, B, 6)`` (NaN rows absent) -> ``(N, K, 6)`` candidates (NaN padded, valid first, in
    slot order then copy order) and ``(N, K)`` source slot index (-1 for padding)."""
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    n = robot.n_joints
    # q in [-pi, pi): a copy q + 2 pi k can be inside [lo, hi] only for these k (a prismatic joint: none)
    kmin = np.where(robot.prismatic, 0, np.floor((lo - np.pi) / (2 * np.pi)).astype(int) + 1)
    kmax = np.where(robot.prismatic, 0, np.ceil((hi + np.pi) / (2 * np.pi)).astype(int) - 1)
    grids = np.meshgrid(*[np.arange(a, b + 1) for a, b in zip(kmin, kmax, strict=True)], indexing="ij")
    shifts = 2 * np.pi * np.stack([g.reshape(-1) for g in grids], axis=1)  # (C, n)
    N, B, _ = q.shape
    cand = q[:, :, None, :] + shifts[None, None]  # (N, B, C, 6)
    ok = np.isfinite(cand).all(axis=3) & ((cand >= lo) & (cand <= hi)).all(axis=3)
    cand = cand.reshape(N, -1, n)
    ok = ok.reshape(N, -1)
    slot = np.broadcast_to(np.repeat(np.arange(B), shifts.shape[0]), ok.shape)
    K = max(int(ok.sum(axis=1).max(initial=0)), 1)
    order = np.argsort(~ok, axis=1, kind="stable")[:, :K]
    taken = np.take_along_axis(ok, order, axis=1)
    out = np.take_along_axis(cand, order[:, :, None], axis=1)
    out[~taken] = np.nan
    src = np.where(taken, np.take_along_axis(slot, order, axis=1), -1)
    return out, src


def solve_all(robot: Robot, poses, *, limits: bool = False, extra_turns: bool = False,
              tol: float = TOL, threads: int | None = None) -> np.ndarray:
    """All closed-form inverse-kinematics solutions of world TCP poses (OPW, UR or SCARA form).

    Base and tool of the model are removed first; each solution is verified by ``robot.fk``.

    Parameters
    ----------
    robot : Robot
        A model with an OPW form (ortho-parallel arm with a spherical wrist), a UR form
        (Universal Robots geometry) or a SCARA form (`robocal.ik.scara`); its base and tool
        frames are taken into account.
    poses : array_like, shape (N, 4, 4) or (4, 4)
        World poses of the TCP, metres.
    limits : bool, default False
        Set the solutions outside the joint limits to NaN (the shape stays ``(N, 8, 6)``; a
        SCARA's ``(N, 2, 4)``).
    extra_turns : bool, default False
        Every candidate inside the limits, including the +-2 pi copies of joints with more than
        a full turn of travel; implies ``limits``.
    tol : float
        Tolerance of the forward-kinematics check, metres and radians.
    threads : int, optional
        Worker threads (default: the CPU count, at most 8).

    Returns
    -------
    numpy.ndarray, shape (N, 8, 6) or (N, K, 6)
        Joints, radians, wrapped to [-pi, pi); NaN where a branch does not exist. The 8 slots are
        the branches in a fixed order (shoulder, elbow, wrist); a SCARA's 2 are its hands (the
        elbow's sign), its quill in m, not wrapped. With ``extra_turns``, K is the largest
        candidate count over the poses, valid rows first, NaN padding.

    Raises
    ------
    ModelError
        The model has no OPW, UR or SCARA form.
    DataError
        ``poses`` are not rigid transforms.

    See Also
    --------
    rc.ik.solve : One solution per target.
    rc.ik.IKResult : What it returns.
    rc.ik.plan_path : Choose among the solutions along a path.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> q = np.array([[0.1, -0.2, 0.3, 0.4, 0.5, 0.6]])
    >>> solutions = rc.ik.solve_all(robot, robot.fk(q))
    >>> solutions.shape
    (1, 8, 6)
    >>> bool(np.isclose(solutions[0], q).all(axis=1).any())  # the joints we started from are a branch
    True
    """
    T = check_poses(poses)
    q = solve_branches(robot, T, tol, threads)
    if extra_turns:
        return turn_copies(robot, q)[0]
    if limits:
        inside = ((q >= robot.limits[:, 0]) & (q <= robot.limits[:, 1])).all(axis=2)
        q[~inside] = np.nan
    return q
