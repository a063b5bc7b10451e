"""Numeric inverse kinematics for any robot model (calibrated ones with beta, any base/tool).

Batched Levenberg-Marquardt on the 6 pose residuals (position m, rotation vector rad, world
frame) with the joint Jacobian, which is the identification Jacobian w.r.t. theta1..thetan
(d TCP / d theta_i = d TCP / d q_i; d_i for a prismatic joint, whose value adds to d_i);
every target is one member of robocal's damped
least-squares loop (:mod:`robocal.core.damped_least_squares`, the one calibration uses), with
Marquardt's diagonal scaling. Seeds default to the closed-form solution of the robot's nominal
model (its OPW or UR form, :mod:`robocal.ik.closed_form`) in the requested branch, with this
robot's base and tool.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

import robocal.ik.scara as scara_ik
from robocal.core.damped_least_squares import Status, minimize
from robocal.core.errors import DataError, UnreachableError
from robocal.ik.closed_form import branch_model, branch_slot, seed_branches, seed_model, solve_branches
from robocal.ik.opw_ik import check_poses
from robocal.ik.scara import is_scara_arm
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform, pose_error

POS_TOL = 1e-10  # m
ROT_TOL = 1e-9  # rad
_DIAG_FLOOR = 1e-12  # added to J^T J's diagonal before Marquardt scaling (a joint with no effect)
RESTART_DEG = 3.0  # how far restarts move a start off a singular elbow or wrist (deg)
WRIST_SPIN_DEG = 30.0  # how far restarts turn joints 4 and 6 about an almost aligned wrist (deg)


@dataclass(frozen=True)
class IKResult:
    """The result of `robocal.ik.solve`.

    Attributes
    ----------
    joints : numpy.ndarray, shape (N, n)
        Joints, radians.
    converged : numpy.ndarray of bool, shape (N,)
        Whether each pose was reached within the tolerances.
    position_error : numpy.ndarray, shape (N,)
        Final position error, metres.
    orientation_error : numpy.ndarray, shape (N,)
        Final orientation error, radians.
    seeds : numpy.ndarray, shape (N, n)
        The starting joints used, radians.
    iterations : int
        The most accepted steps any target took over all its runs.

    See Also
    --------
    rc.ik.solve_all : Returns it.
    rc.ik.solve : Returns it.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> result = rc.ik.solve(robot, robot.fk(np.zeros((2, 6))), seeds=np.full((2, 6), 0.1))
    >>> result.joints.shape, result.failed.size
    ((2, 6), 0)
    """

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

    def __init__(self, robot: Robot, T: np.ndarray, q0: np.ndarray, pos_tol: float, rot_tol: float,
                 free: np.ndarray):
        self.robot, self.T, self.tol = robot, T, (pos_tol, rot_tol)
        self.free = free
        self.names = [robot.joint_params[i] for i in free]
        self.size = T.shape[0]
        self.q = q0.copy()
        self.err = pose_error(T, robot.fk(self.q))
        self.c = np.einsum("ij,ij->i", self.err, self.err)
        self.J = np.zeros((self.size, 6, len(free)))
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
        step = np.linalg.solve(A, g[:, :, None])[:, :, 0]
        self.step[np.ix_(m, self.free)] = step
        left = err - np.einsum("kri,ki->kr", J, step)
        return self.c[m] - np.einsum("kr,kr->k", left, left)

    def converged(self, m: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        return _within(self.err[m], self.tol)

    def trial_cost(self, m: np.ndarray) -> np.ndarray:
        self.q_trial[m] = self.q[m] + self.step[m]
        self.err_trial[m] = pose_error(self.T[m], self.robot.fk(self.q_trial[m]))
        self.c_trial[m] = np.einsum("ij,ij->i", self.err_trial[m], self.err_trial[m])
        return self.c_trial[m]

    def accept(self, m: np.ndarray) -> None:
        self.q[m], self.err[m], self.c[m] = self.q_trial[m], self.err_trial[m], self.c_trial[m]


def _nominal_model(robot: Robot, nominal: Robot | None) -> Robot:
    """The closed-form model seeding IK on ``robot`` (:func:`robocal.ik.closed_form.seed_model` of
    ``nominal``, default the robot's own nominal model) with the robot's base and tool (a seed model
    whose chain is written otherwise, the nearest OPW arm's, keeps its frames' share of the placement)."""
    source = robot.nominal_robot() if nominal is None else nominal
    model = seed_model(source)
    return model.with_frames(base=robot.base @ invert_transform(source.base) @ model.base,
                             tool=model.tool @ invert_transform(source.tool) @ robot.tool)


def seeded_branches(robot: Robot, T: np.ndarray) -> np.ndarray:
    """All 8 solutions ``(N, 8, 6)`` (rad, NaN where none) for checked world poses ``T``: the
    robot's own closed form, or for a robot without one whose :func:`robocal.ik.closed_form.seed_model`
    has one (a factory-calibrated UR), that model's solutions refined by numeric IK on the robot
    (slot by slot: each stays in its branch)."""
    form = seed_model(robot)
    if form is robot:
        return solve_branches(robot, T)  # its own closed form (or the error saying it has none)
    seeds = solve_branches(form, T).reshape(-1, robot.n_joints)
    has = np.isfinite(seeds).all(axis=1)
    out = np.full_like(seeds, np.nan)
    if has.any():
        res = solve(robot, np.repeat(T, 8, axis=0)[has], seeds[has], nominal=robot)
        out[np.flatnonzero(has)[res.converged]] = res.joints[res.converged]
    return out.reshape(T.shape[0], 8, robot.n_joints)


def nominal_branches(robot: Robot, T: np.ndarray,
                     nominal: Robot | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Seeds ``(N, 8, 6)`` (rad) per branch slot for checked world poses ``T``: the closed-form
    solution of the nominal model (``nominal``, default the robot's own, with this robot's base
    and tool) where it exists, else the clamped closed form (:func:`robocal.ik.closed_form.seed_branches`:
    the target is a little beyond the nominal reach, which the robot may still reach); and
    ``(N, 8)`` whether the exact one exists."""
    model = _nominal_model(robot, nominal)
    sols = solve_branches(model, T)
    exists = np.isfinite(sols).all(axis=2)
    missing = np.flatnonzero(~exists.all(axis=1))
    if missing.size:
        sols[missing] = np.where(exists[missing, :, None], sols[missing], seed_branches(model, T[missing]))
    return sols, exists


def _nominal_candidates(robot: Robot, T: np.ndarray, nominal: Robot | None = None) -> np.ndarray:
    """Seeds ``(N, 8, 6)`` ordered per pose: the nominal solutions inside the limits first, then
    the other existing ones, then the clamped seeds, each group in slot order."""
    sols, exists = nominal_branches(robot, T, nominal)
    inside = exists & ((sols >= robot.limits[:, 0]) & (sols <= robot.limits[:, 1])).all(axis=2)
    rank = np.where(inside, 0, np.where(exists, 1, 2)) * 8 + np.arange(8)
    order = np.argsort(rank, axis=1)
    return np.take_along_axis(sols, order[:, :, None], axis=1)


def nominal_seeds(robot: Robot, T: np.ndarray, branch: int | None = None,
                  nominal: Robot | None = None) -> np.ndarray:
    """Closed-form seeds ``(N, 6)`` from the nominal links (``nominal``, default the robot's own
    nominal model) with this robot's base and tool.

    ``branch`` picks the slot (0..7, see :mod:`robocal.ik.closed_form`); None takes, per pose, the
    lowest slot inside the joint limits, else the lowest that exists. Where the nominal model has
    no solution in the slot, the clamped closed form seeds it (see :func:`nominal_branches`).
    """
    if branch is not None:
        if not 0 <= int(branch) < 8:
            raise DataError(f"branch must be 0..7 (slot = 4 * wrist_flip + 2 * shoulder + elbow), "
                            f"got {branch}")
        return nominal_branches(robot, T, nominal)[0][:, int(branch)]
    return _nominal_candidates(robot, T, nominal)[:, 0]


def _within(err: np.ndarray, tol: tuple[float, float]) -> np.ndarray:
    """``(N,)`` bool: pose errors ``(N, 6)`` within (position m, rotation rad) ``tol``."""
    return (np.linalg.norm(err[:, :3], axis=1) <= tol[0]) & (np.linalg.norm(err[:, 3:], axis=1) <= tol[1])


class _Run(NamedTuple):
    """Where damped runs left their targets: joints ``(N, n)``, pose errors ``(N, 6)``, converged
    ``(N,)`` (errors within the tolerances), how the last run stopped ``(N,)`` (:class:`Status`)
    and accepted steps ``(N,)`` over all runs."""

    q: np.ndarray
    err: np.ndarray
    ok: np.ndarray
    status: np.ndarray
    nit: np.ndarray

    def rows(self, rows: np.ndarray) -> _Run:
        """A copy of the targets ``rows``."""
        return _Run(*(v[rows].copy() for v in self))

    def take(self, rows: np.ndarray, other: _Run, which: np.ndarray) -> None:
        """Targets ``rows[which]`` <- ``other``'s ``which`` (steps: ``other``'s are added to all ``rows``)."""
        self.nit[rows] += other.nit
        for have, new in zip(self[:4], other[:4], strict=True):
            have[rows[which]] = new[which]


def _free_joints(robot: Robot, locked) -> np.ndarray:
    """Indices of the joints IK moves: all but ``locked`` (0-based indices, e.g. a track's joint
    held at the program's own value)."""
    locked = set() if locked is None else {int(i) for i in locked}
    if not locked <= set(range(robot.n_joints)):
        raise DataError(f"locked joints must be indices 0..{robot.n_joints - 1}, got {sorted(locked)}")
    return np.array([i for i in range(robot.n_joints) if i not in locked], dtype=int)


def _descend(robot: Robot, T: np.ndarray, q0: np.ndarray, max_iter: int, tol: tuple[float, float],
             locked=None) -> _Run:
    """The damped loop from ``q0`` ``(N, n)``, the ``locked`` joints held at their start."""
    targets = _Targets(robot, T, q0, *tol, _free_joints(robot, locked))
    out = minimize(targets, max_iter)
    return _Run(targets.q, targets.err, _within(targets.err, tol), out.status, out.nit)


def _restart_offsets(n: int) -> np.ndarray:
    """``(K, n)`` joint offsets (rad) that move a start off a singular configuration: +-RESTART_DEG
    on the shoulder, elbow and wrist-bend joints (2, 3, 5), one at a time and the elbow with each;
    and, for a wrist near alignment (where only the sum or the difference of joints 4 and 6
    matters and the split between them is barely determined), joints 4 and 6 turned by
    +-WRIST_SPIN_DEG the same and the opposite way."""
    step, spin = np.deg2rad(RESTART_DEG), np.deg2rad(WRIST_SPIN_DEG)
    offsets = []
    for joints, steps in (((1,), (step,)), ((2,), (step,)), ((4,), (step,)), ((1, 2), (step, step)),
                          ((2, 4), (step, step)), ((3, 5), (spin, spin)), ((3, 5), (spin, -spin))):
        for sign in (1.0, -1.0):
            d = np.zeros(n)
            for j, v in zip(joints, steps, strict=True):
                if j < n:
                    d[j] = sign * v
            offsets.append(d)
    return np.unique(np.array(offsets), axis=0)


def _restarts(robot: Robot, T: np.ndarray, q0: np.ndarray, max_iter: int, tol: tuple[float, float],
              form: Robot | None, locked=None) -> _Run:
    """Targets restarted from their seeds ``q0`` ``(N, n)`` moved off a nearby singularity
    (:func:`_restart_offsets`): per target the converged restart nearest the seed, in the seed's
    branch (by the closed form of the nominal model ``form`` when there is one); ``nit`` counts each target's
    longest restart."""
    offsets = _restart_offsets(robot.n_joints)
    if locked is not None:
        offsets[:, list(locked)] = 0.0
    N, K = len(q0), len(offsets)
    starts = (q0[:, None, :] + offsets[None]).reshape(-1, robot.n_joints)
    run = _descend(robot, np.repeat(T, K, axis=0), starts, max_iter, tol, locked)
    qs, oks = run.q.reshape(N, K, -1), run.ok.reshape(N, K)
    if form is not None:  # the controller asked for the seed's branch
        oks &= branch_slot(form, qs) == branch_slot(form, q0)[:, None]
    dist = np.where(oks, np.abs(np.remainder(qs - q0[:, None] + np.pi, 2 * np.pi) - np.pi).sum(-1), np.inf)
    pick = np.arange(N) * K + np.argmin(dist, axis=1)
    return _Run(run.q[pick], run.err[pick], oks.reshape(-1)[pick], run.status[pick],
                run.nit.reshape(N, K).max(axis=1))


def _retry(robot: Robot, T: np.ndarray, q0: np.ndarray, run: _Run, max_iter: int, tol: tuple[float, float],
           form: Robot | None, locked=None) -> None:
    """The targets of ``run`` (from seeds ``q0``) not reached, in place: those stopped at the
    iteration limit (slow convergence near a singular wrist or elbow) continue for another
    ``max_iter`` steps (continuing a stalled one would repeat its stall); those still not reached
    restart from the seed moved off the singularity (:func:`_restarts`)."""
    seeded = np.isfinite(q0).all(axis=1)
    rows = np.flatnonzero(~run.ok & seeded & (run.status == Status.MAX_ITERATIONS))
    if rows.size:
        run.take(rows, _descend(robot, T[rows], run.q[rows], max_iter, tol, locked),
                 np.ones(rows.size, bool))
    rows = np.flatnonzero(~run.ok & seeded)
    if rows.size:
        again = _restarts(robot, T[rows], q0[rows], max_iter, tol, form, locked)
        run.take(rows, again, again.ok)


def _result(robot: Robot, q0: np.ndarray, run: _Run) -> IKResult:
    """The IKResult of ``run`` from seeds ``q0`` (NaN rows: no seed, not converged): joints on the
    seed's turn (joints with more than 360 deg of travel), then moved into the limits by a turn
    where that turn lands inside them (a joint just past a limit stays there, to be reported)."""
    seeded = np.isfinite(q0).all(axis=1)
    start = np.where(np.isfinite(q0), q0, 0.0)
    q = np.where(robot.prismatic, run.q, start + (np.remainder(run.q - start + np.pi, 2 * np.pi) - np.pi))
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    up, down = q + 2 * np.pi, q - 2 * np.pi
    q = np.where((q < lo) & (up <= hi), up, np.where((q > hi) & (down >= lo), down, q))
    return IKResult(q, run.ok & seeded, np.linalg.norm(run.err[:, :3], axis=1),
                    np.linalg.norm(run.err[:, 3:], axis=1), np.array(q0), int(run.nit.max(initial=0)))


def _solve_from(robot: Robot, T: np.ndarray, q0: np.ndarray, nominal: Robot | None, max_iter: int,
                tol: tuple[float, float], retry: bool, locked=None) -> tuple[IKResult, _Run]:
    """IK from seeds ``q0`` ``(N, n)`` (NaN rows: no seed, not converged), with the singular-case
    retries of :func:`_retry` when ``retry``; also the run (raw joints, steps) behind the result.
    The ``locked`` joints stay at their seed."""
    run = _descend(robot, T, np.where(np.isfinite(q0), q0, 0.0), max_iter, tol, locked)
    if retry:
        _retry(robot, T, q0, run, max_iter, tol, branch_model(robot, nominal), locked)
    return _result(robot, q0, run), run


def _update(res: IKResult, rows: np.ndarray, alt: IKResult) -> None:
    """Take ``alt``'s converged rows into ``res`` at ``rows``."""
    take = rows[alt.converged]
    for field in ("joints", "seeds", "position_error", "orientation_error"):
        arr, new = getattr(res, field), getattr(alt, field)
        arr[take] = new[alt.converged]
    res.converged[take] = True


def solve(robot: Robot, poses, seeds=None, *, branch: int | None = None, nominal: Robot | None = None,
          max_iter: int = 100, pos_tol: float = POS_TOL, rot_tol: float = ROT_TOL, strict: bool = False,
          locked=None) -> IKResult:
    """Numeric inverse kinematics of any model, calibrated ones included.

    Damped least squares from a seed per pose. Targets not reached are retried: continued if they
    stopped at ``max_iter``, then restarted from their seed moved off a nearby singularity.

    Parameters
    ----------
    robot : Robot
        The model whose TCP is to reach the poses (any serial chain).
    poses : array_like, shape (N, 4, 4) or (4, 4)
        World poses of the TCP, metres.
    seeds : array_like, shape (N, n), optional
        Starting joints, radians. Default: the nominal closed-form solution in ``branch`` (needs
        an OPW or UR form on ``nominal`` or on the robot's own nominal model); with neither
        ``seeds`` nor ``branch``, each pose starts from its preferred nominal branch and tries the
        next ones where that fails (inside the limits first).
    branch : int, optional
        Closed-form branch slot (0-7) of the seeds.
    nominal : Robot, optional
        The model whose closed form seeds the search (e.g. the controller's nominal model).
    max_iter : int, default 100
        Accepted steps per run of the damped loop.
    pos_tol, rot_tol : float
        Convergence: position error <= ``pos_tol`` (m, default 1e-10) and rotation error <=
        ``rot_tol`` (rad, default 1e-9).
    strict : bool, default False
        Raise instead of flagging poses that do not converge.
    locked : sequence of int, optional
        0-based indices of joints held at their seed (needs ``seeds``), e.g. a track's joint at the
        program's own value (see `robocal.ik.track`). A chain with a prismatic joint needs ``seeds``.

    Returns
    -------
    IKResult
        ``joints`` (N, n) rad, ``converged`` (N,), the final ``position_error`` (m) and
        ``orientation_error`` (rad) per pose, the ``seeds`` used and ``iterations`` (the most
        accepted steps any target took over all its runs).

    Raises
    ------
    UnreachableError
        With ``strict=True``: the poses that did not converge, listed.

    See Also
    --------
    rc.ik.solve_all : Every solution of each target.
    rc.ik.IKResult : What it returns.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("ur5e")
    >>> q = np.array([[0.3, -1.2, 1.4, -0.5, 1.1, 0.2]])
    >>> result = rc.ik.solve(robot, robot.fk(q), seeds=q + 0.05)
    >>> bool(result.converged.all()), bool(np.allclose(result.joints, q))
    (True, True)
    """
    T = check_poses(poses)
    N, n = T.shape[0], robot.n_joints
    tol = (pos_tol, rot_tol)
    if locked is None and is_scara_arm(robot):  # 4 tasks: a SCARA cannot tilt (robocal.ik.scara)
        return _finish(_scara(robot, T, branch, seeds), N, pos_tol, rot_tol, strict)
    if seeds is None and (locked is not None or robot.has_prismatic):
        raise DataError(f"{robot.name}: IK of a chain with prismatic or locked joints needs seeds (for an "
                        "arm on a track: robocal.ik.track.solve)")
    if seeds is None and branch is None:
        # per pose the preferred nominal branch; where the robot has no solution in it, the next
        # branch in preference order; the singular-case retries only where every branch failed
        cands = _nominal_candidates(robot, T, nominal)
        res, first = _solve_from(robot, T, cands[:, 0], nominal, max_iter, tol, retry=False)
        nit = first.nit.copy()
        for b in range(1, 8):
            rows = np.flatnonzero(~res.converged & np.isfinite(cands[:, b]).all(axis=1))
            if rows.size:
                alt, run = _solve_from(robot, T[rows], cands[rows, b], nominal, max_iter, tol, False)
                _update(res, rows, alt)
                nit[rows] += run.nit
        rows = res.failed
        if rows.size:  # the preferred branch's retries, from where its first run stopped
            run = first.rows(rows)
            _retry(robot, T[rows], cands[rows, 0], run, max_iter, tol, branch_model(robot, nominal))
            _update(res, rows, _result(robot, cands[rows, 0], run))
            nit[rows] += run.nit - first.nit[rows]
        return _finish(replace(res, iterations=int(nit.max(initial=0))), N, pos_tol, rot_tol, strict)
    if seeds is None:
        q0 = nominal_seeds(robot, T, branch, nominal)
    else:
        q0 = np.asarray(seeds, dtype=float)
        if q0.shape == (n,):
            q0 = np.broadcast_to(q0, (N, n))
        if q0.shape != (N, n):
            raise DataError(f"seeds must have shape ({N}, {n}), got {q0.shape}")
    return _finish(_solve_from(robot, T, q0, nominal, max_iter, tol, retry=True, locked=locked)[0], N,
                   pos_tol, rot_tol, strict)


def _scara(robot: Robot, T: np.ndarray, branch: int | None, given: np.ndarray | None) -> IKResult:
    """A SCARA (or a calibrated model of one): each target from the planar closed form of the
    robot's own chain in ``branch`` (default: the first branch that converges inside the limits),
    refined on its 4 tasks (:mod:`robocal.ik.scara`: position and the turn about its axis; a SCARA
    cannot tilt, so the orientation error reported is the turn's); ``given`` seeds ``(N, 4)`` or
    ``(4,)`` replace the closed form's."""
    seeds = scara_ik.seed_branches(robot, T)
    if given is not None:
        seeds = np.broadcast_to(np.asarray(given, float), (T.shape[0], 4))[:, None, :]
        branch = 0
    if branch is not None and int(branch) not in range(scara_ik.BRANCHES):
        raise DataError(f"{robot.name} is a SCARA: its branches are 0 (elbow positive) and 1 (negative), "
                        f"not {branch}")
    order = range(scara_ik.BRANCHES) if branch is None else [int(branch)]
    N = T.shape[0]
    q, err = seeds[:, order[0]].copy(), np.full((N, 4), np.inf)
    done = np.zeros(N, bool)
    for b in order:
        rows = np.flatnonzero(~done)
        qb, eb = scara_ik.refine(robot, T[rows], seeds[rows, b])
        ok = scara_ik.converged(eb) & robot.within_limits(qb)
        better = ok | (np.linalg.norm(eb[:, :3], axis=1) < np.linalg.norm(err[rows, :3], axis=1))
        q[rows[better]], err[rows[better]] = qb[better], eb[better]
        done[rows[ok]] = True
    ok = scara_ik.converged(err)
    return IKResult(joints=q, converged=ok, position_error=np.linalg.norm(err[:, :3], axis=1),
                    orientation_error=np.abs(err[:, 3]), seeds=seeds[:, order[0]],
                    iterations=0)


def _finish(result: IKResult, N: int, pos_tol: float, rot_tol: float, strict: bool) -> IKResult:
    pe = result.position_error
    if strict and not result.converged.all():
        bad = result.failed
        raise UnreachableError(
            f"numeric IK did not reach {bad.size} of {N} pose(s) to {pos_tol:g} m / {rot_tol:g} rad: "
            f"indices {bad[:20].tolist()}{' ...' if bad.size > 20 else ''} (worst position error "
            f"{pe[bad].max() * 1e3:.3g} mm); the targets may be out of reach or the seeds too far")
    return result
