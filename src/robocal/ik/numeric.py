"""Numeric inverse kinematics for any robot model (calibrated ones with beta, any base/tool).

Batched Levenberg-Marquardt on the 6 pose residuals (position m, rotation vector rad, world
frame) with the joint Jacobian, which is the identification Jacobian w.r.t. theta1..thetan
(d TCP / d theta_i = d TCP / d q_i); every target is one member of robocal's damped
least-squares loop (:mod:`robocal.damped_least_squares`, the one calibration uses), with
Marquardt's diagonal scaling. Seeds default to the closed-form solution of the robot's nominal
model (its OPW form) in the requested branch, with this robot's base and tool.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.damped_least_squares import minimize
from robocal.errors import DataError, UnreachableError
from robocal.ik.opw_ik import check_poses, solve_branches
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import pose_error

POS_TOL = 1e-10  # m
ROT_TOL = 1e-9  # rad
_DIAG_FLOOR = 1e-12  # added to J^T J's diagonal before Marquardt scaling (a joint with no effect)


@dataclass(frozen=True)
class IKResult:
    """Joints ``(N, n)`` rad, ``converged`` ``(N,)``, final ``position_error`` ``(N,)`` m and
    ``orientation_error`` ``(N,)`` rad, the seeds used ``(N, n)`` and the iteration count."""

    joints: np.ndarray
    converged: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    seeds: np.ndarray
    iterations: int

    @property
    def failed(self) -> np.ndarray:
        """Indices of the poses that did not converge."""
        return np.flatnonzero(~self.converged)


class _Targets:
    """A batch of IK targets as the members of the damped loop (see DampedProblem)."""

    def __init__(self, robot: Robot, T: np.ndarray, q0: np.ndarray, pos_tol: float, rot_tol: float):
        self.robot, self.T, self.tol = robot, T, (pos_tol, rot_tol)
        self.names = [f"theta{i + 1}" for i in range(robot.n_joints)]
        self.size = T.shape[0]
        self.q = q0.copy()
        self.err = pose_error(T, robot.fk(self.q))
        self.c = np.einsum("ij,ij->i", self.err, self.err)
        self.J = np.zeros((self.size, 6, robot.n_joints))
        self.step = np.zeros_like(self.q)
        self.q_trial, self.err_trial, self.c_trial = self.q.copy(), self.err.copy(), self.c.copy()

    def cost(self) -> np.ndarray:
        return self.c

    def linearize(self, m: np.ndarray) -> None:
        self.J[m] = self.robot.jacobian(self.q[m], self.names, kind="pose")

    def propose(self, m: np.ndarray, damping: np.ndarray) -> np.ndarray:
        J, err = self.J[m], self.err[m]
        JtJ = np.einsum("kri,krj->kij", J, J)
        g = np.einsum("kri,kr->ki", J, err)
        diag = np.einsum("kii->ki", JtJ)
        A = JtJ + (damping[:, None] * (diag + _DIAG_FLOOR))[:, :, None] * np.eye(J.shape[2])
        self.step[m] = np.linalg.solve(A, g[:, :, None])[:, :, 0]
        left = err - np.einsum("kri,ki->kr", J, self.step[m])
        return self.c[m] - np.einsum("kr,kr->k", left, left)

    def converged(self, m: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        err = self.err[m]
        return ((np.linalg.norm(err[:, :3], axis=1) <= self.tol[0])
                & (np.linalg.norm(err[:, 3:], axis=1) <= self.tol[1]))

    def trial_cost(self, m: np.ndarray) -> np.ndarray:
        self.q_trial[m] = self.q[m] + self.step[m]
        self.err_trial[m] = pose_error(self.T[m], self.robot.fk(self.q_trial[m]))
        self.c_trial[m] = np.einsum("ij,ij->i", self.err_trial[m], self.err_trial[m])
        return self.c_trial[m]

    def accept(self, m: np.ndarray) -> None:
        self.q[m], self.err[m], self.c[m] = self.q_trial[m], self.err_trial[m], self.c_trial[m]


def _nominal_model(robot: Robot, nominal: Robot | None) -> Robot:
    return (robot.nominal_robot() if nominal is None else nominal).with_frames(base=robot.base,
                                                                                tool=robot.tool)


def _nominal_candidates(robot: Robot, T: np.ndarray, nominal: Robot | None = None) -> np.ndarray:
    """Nominal closed-form solutions ``(N, 8, 6)`` ordered per pose: inside the limits first,
    then the rest that exist, each in slot order; NaN rows last."""
    sols = solve_branches(_nominal_model(robot, nominal), T)
    exists = np.isfinite(sols).all(axis=2)
    inside = exists & ((sols >= robot.limits[:, 0]) & (sols <= robot.limits[:, 1])).all(axis=2)
    rank = np.where(inside, 0, np.where(exists, 1, 2)) * 8 + np.arange(8)
    order = np.argsort(rank, axis=1)
    return np.take_along_axis(sols, order[:, :, None], axis=1)


def nominal_seeds(robot: Robot, T: np.ndarray, branch: int | None = None,
                  nominal: Robot | None = None) -> np.ndarray:
    """Closed-form seeds ``(N, 6)`` from the nominal links (``nominal``, default the robot's own
    nominal model) with this robot's base and tool.

    ``branch`` picks the slot (0..7, see :mod:`robocal.ik.opw_ik`); None takes, per pose, the
    lowest slot inside the joint limits, else the lowest that exists. Rows without a closed-form
    solution are NaN (those poses are then reported as not converged).
    """
    if branch is not None:
        if not 0 <= int(branch) < 8:
            raise DataError(f"branch must be 0..7 (slot = 4 * wrist_flip + 2 * shoulder + elbow), "
                            f"got {branch}")
        return solve_branches(_nominal_model(robot, nominal), T)[:, int(branch)]
    return _nominal_candidates(robot, T, nominal)[:, 0]


def solve(robot: Robot, poses, seeds=None, *, branch: int | None = None, nominal: Robot | None = None,
          max_iter: int = 100,
          pos_tol: float = POS_TOL, rot_tol: float = ROT_TOL, strict: bool = False) -> IKResult:
    """Numeric IK: joints (rad) putting the TCP of ``robot`` at world ``poses`` ``(N, 4, 4)`` (m).

    ``seeds``: ``(N, n)`` starting joints (rad), or None for the nominal closed-form solution
    in ``branch`` (see :func:`nominal_seeds`; needs an OPW form on the nominal model, ``nominal``
    or the robot's own); with
    neither, each pose starts from its preferred nominal branch and, if that fails, tries the
    next ones (inside the limits first, then slot order). Converged
    means position error <= ``pos_tol`` (1e-10 m) and rotation error <= ``rot_tol`` (1e-9 rad).
    Poses that do not converge are flagged in ``converged``; ``strict=True`` raises
    UnreachableError listing them instead.
    """
    T = check_poses(poses)
    N, n = T.shape[0], robot.n_joints
    if seeds is None and branch is None:
        # per pose the preferred nominal branch; where the calibrated model has no solution in
        # it (e.g. near a stretched arm), the next branch in preference order
        cands = _nominal_candidates(robot, T, nominal)
        res = solve(robot, T, cands[:, 0], max_iter=max_iter, pos_tol=pos_tol, rot_tol=rot_tol)
        for b in range(1, 8):
            retry = np.flatnonzero(~res.converged & np.isfinite(cands[:, b]).all(axis=1))
            if retry.size == 0:
                break
            alt = solve(robot, T[retry], cands[retry, b], max_iter=max_iter, pos_tol=pos_tol,
                        rot_tol=rot_tol)
            take = retry[alt.converged]
            for arr, new in ((res.joints, alt.joints), (res.seeds, alt.seeds)):
                arr[take] = new[alt.converged]
            res.converged[take] = True
            res.position_error[take] = alt.position_error[alt.converged]
            res.orientation_error[take] = alt.orientation_error[alt.converged]
        return _finish(res, N, pos_tol, rot_tol, strict)
    if seeds is None:
        q0 = nominal_seeds(robot, T, branch, nominal)
    else:
        q0 = np.asarray(seeds, dtype=float)
        if q0.shape == (n,):
            q0 = np.broadcast_to(q0, (N, n))
        if q0.shape != (N, n):
            raise DataError(f"seeds must have shape ({N}, {n}), got {q0.shape}")
    targets = _Targets(robot, T, np.where(np.isfinite(q0), q0, 0.0), pos_tol, rot_tol)
    loop = minimize(targets, max_iter)
    q, err, it = targets.q, targets.err, int(loop.nit.max(initial=0))
    pe = np.linalg.norm(err[:, :3], axis=1)
    re = np.linalg.norm(err[:, 3:], axis=1)
    converged = (pe <= pos_tol) & (re <= rot_tol) & np.isfinite(q0).all(axis=1)
    # stay on the seed's turn (joints with more than 360 deg of travel), then into the limits
    seed = np.where(np.isfinite(q0), q0, 0.0)
    q = seed + (np.remainder(q - seed + np.pi, 2 * np.pi) - np.pi)
    q = np.where(q < robot.limits[:, 0], q + 2 * np.pi, np.where(q > robot.limits[:, 1], q - 2 * np.pi, q))
    return _finish(IKResult(q, converged, pe, re, np.array(q0), it), N, pos_tol, rot_tol, strict)


def _finish(result: IKResult, N: int, pos_tol: float, rot_tol: float, strict: bool) -> IKResult:
    pe = result.position_error
    if strict and not result.converged.all():
        bad = result.failed
        raise UnreachableError(
            f"numeric IK did not reach {bad.size} of {N} pose(s) to {pos_tol:g} m / {rot_tol:g} rad: "
            f"indices {bad[:20].tolist()}{' ...' if bad.size > 20 else ''} (worst position error "
            f"{pe[bad].max() * 1e3:.3g} mm); the targets may be out of reach or the seeds too far")
    return result
