"""Globally optimal choice of IK branches along a trajectory (seed 001).

Per waypoint, every closed-form solution inside the joint limits (with the +-2 pi copies of
joints that travel more than 360 deg) is a node; nodes of consecutive waypoints are joined by
directed edges of cost ``sum_i w_i |dq_i|``; a start node S joins the first layer and an end node
T the last; Dijkstra (``scipy.sparse.csgraph``) from S to T picks one node per waypoint so that
the whole trajectory's weighted joint travel is minimal. A calibrated model (whose chain no
longer follows its OPW or UR form) gets its candidates from the nominal closed form in each branch,
refined by numeric IK on the calibrated model.

Default weights (:func:`default_weights`): ``w_i = 1 + rho_i`` for the three arm joints, with
rho_i (m) the distance from joint axis i to the flange origin at zero joints (the lever the
joint swings), and ``w_4..w_n = 1`` (a chain of any length n): the cost is joint travel in rad
plus, for the big joints, roughly the arc the flange sweeps in m, so big joints cost more ("move
the small joints, spare the big ones").
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

import robocal.ik.scara as scara_ik
from robocal.core.errors import DataError, ModelError, UnreachableError
from robocal.core.io import write_atomic
from robocal.ik.closed_form import branch_model, branch_slot, solve_branches, turn_copies
from robocal.ik.numeric import nominal_branches
from robocal.ik.numeric import solve as ik_solve
from robocal.ik.opw_ik import check_poses
from robocal.ik.scara import is_scara_arm
from robocal.kinematics.cell import is_track_cell
from robocal.kinematics.model import Robot

_TIE_BREAK = 1e-9  # weight of the first waypoint's distance from zero (rad): breaks exact ties only
_BRANCH_JOINTS = 6  # the closed forms (OPW, UR) and so the branches exist for 6-joint arms (and a SCARA)
_EDGE_CHUNK = 4_000_000  # pair evaluations per block when building edges (bounds memory)


@dataclass(frozen=True)
class PathResult:
    """The result of `robocal.ik.plan_path`.

    Attributes
    ----------
    joints : numpy.ndarray, shape (M, n)
        The optimal joints, radians.
    cost : float
        Their weighted joint travel.
    greedy_joints : numpy.ndarray, shape (M, n)
        The greedy choice (nearest candidate step by step), radians, for comparison.
    greedy_cost : float
        Its weighted joint travel.
    weights : numpy.ndarray, shape (n,)
        The weights used.
    slots : numpy.ndarray of int, shape (M,)
        The closed-form branch slot of each chosen joint vector.
    candidates : numpy.ndarray of int, shape (M,)
        How many candidates each waypoint had.
    joint_specs : tuple of JointSpec
        The robot's joints (`Robot.joints`): each one's column and unit in the joints file (a
        track's carriage ``e1_mm`` first, kept where the poses put it).
    warnings : list of str
        None today: a waypoint without a solution is refused.

    See Also
    --------
    rc.ik.plan_path : The planner that returns it.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("ur5e")
    >>> q = np.linspace([0.0, -1.2, 1.3, -0.4, 1.2, 0.0], [0.6, -1.0, 1.5, -0.2, 1.4, 0.5], 4)
    >>> path = rc.ik.plan_path(robot, robot.fk(q))
    >>> path.slots.shape, int(path.candidates.min()) >= 1
    ((4,), True)
    """

    joints: np.ndarray
    cost: float
    greedy_joints: np.ndarray
    greedy_cost: float
    weights: np.ndarray
    slots: np.ndarray
    candidates: np.ndarray
    joint_specs: tuple = ()
    warnings: list[str] = field(default_factory=list)

    @property
    def saving(self) -> float:
        """How much less the optimal path travels than the greedy one, percent."""
        return 100.0 * (1.0 - self.cost / self.greedy_cost) if self.greedy_cost > 0 else 0.0

    def summary(self) -> str:
        """The weights and the optimal and greedy weighted travel.

        Returns
        -------
        str
            The summary text.
        """
        return (f"weights {np.round(self.weights, 4).tolist()}\n"
                f"optimal total weighted travel {self.cost:.6g}\n"
                f"greedy  total weighted travel {self.greedy_cost:.6g} (optimal saves {self.saving:.1f}%)")

    def to_dict(self) -> dict:
        """The joints (rad; a track's carriage m), the costs, the weights and the branch slots.

        Returns
        -------
        dict
            The path (JSON-ready).
        """
        return {"joints": self.joints.tolist(), "cost": self.cost, "greedy_cost": self.greedy_cost,
                "weights": self.weights.tolist(), "slots": self.slots.tolist()}

    def write(self, path) -> list[str]:
        """Write the joints CSV (each joint under its column in its unit: ``q1_deg..``, a track's
        ``e1_mm`` first, a quill's ``q3_mm``) atomically; the paths written.

        Parameters
        ----------
        path : str or pathlib.Path
            The joints CSV.

        Returns
        -------
        list of str
            The paths written.
        """
        columns = [j.column for j in self.joint_specs]
        shown = np.column_stack([j.shown(self.joints[:, k]) for k, j in enumerate(self.joint_specs)])
        lines = [",".join(columns)] + [",".join(repr(float(v)) for v in row) for row in shown.tolist()]
        write_atomic(path, "\n".join(lines) + "\n")
        return [str(path)]


def default_weights(robot: Robot, wrist=(1.0, 1.0, 1.0)) -> np.ndarray:
    """``(n,)`` weights: 1 + lever arm (m) from axis i to the flange at zero joints for the first
    three revolute joints, ``wrist`` for the next ones (repeated on a longer chain); a prismatic
    joint (a track) 1 per metre of travel.

    The big joints move more mass, so `plan_path` charges their travel more.

    Parameters
    ----------
    robot : Robot
        The model (its zero pose gives the lever arms).
    wrist : sequence of float, default (1, 1, 1)
        The weights of the revolute joints after the third (repeated on a longer chain).

    Returns
    -------
    numpy.ndarray, shape (n,)
        Weight per joint, per radian of travel (dimensionless, 1 + metres for the first three).

    See Also
    --------
    rc.ik.plan_path : Uses them.

    Examples
    --------
    >>> import robocal as rc
    >>> rc.ik.default_weights(rc.Robot.from_catalog("abb_irb2600")).round(2)
    array([2.03, 2.2 , 1.89, 1.  , 1.  , 1.  ])
    """
    n = robot.n_joints
    _, frames = robot.fk(np.zeros((1, n)), frames=True)
    flange = frames[0, n, :3, 3]
    w = np.ones(n)
    turning = np.flatnonzero(~robot.prismatic)
    for i in turning[:3]:
        o, z = frames[0, i + 1, :3, 3], frames[0, i + 1, :3, 2]
        v = flange - o
        w[i] = 1.0 + np.linalg.norm(v - (v @ z) * z)
    if turning.size > 3:
        w[turning[3:]] = np.resize(np.asarray(wrist, dtype=float), turning.size - 3)
    return w


def check_weights(weights, n: int) -> np.ndarray:
    """Weights as ``(n,)`` finite non-negative floats, else DataError."""
    w = np.asarray(weights, dtype=float).reshape(-1)
    if w.shape != (n,):
        raise DataError(f"weights must have {n} values (one per joint), got {w.size}")
    if not np.isfinite(w).all() or (w < 0).any():
        raise DataError(f"weights must be finite and >= 0, got {w.tolist()}")
    return w


def travel(q: np.ndarray, weights: np.ndarray, start: np.ndarray | None = None) -> float:
    """Weighted joint travel ``sum_m sum_i w_i |q[m+1, i] - q[m, i]|`` (from ``start`` if given)."""
    if start is not None:
        q = np.vstack([start, q])
    return float((np.abs(np.diff(q, axis=0)) @ weights).sum())


def _greedy(cand: np.ndarray, valid: np.ndarray, w: np.ndarray, first: np.ndarray) -> np.ndarray:
    M = cand.shape[0]
    out = np.empty((M, cand.shape[2]))
    prev = first
    for m in range(M):  # sequential by nature: each choice depends on the previous one
        d = np.where(valid[m], np.abs(cand[m] - prev) @ w, np.inf)
        prev = out[m] = cand[m, np.argmin(d)]
    return out


def branch_candidates(robot: Robot, T: np.ndarray, nominal: Robot | None = None) -> np.ndarray:
    """The 8 branches ``(M, 8, 6)`` (rad, NaN where absent) of checked poses ``T``: closed form
    when the robot has a closed form (OPW or UR), else (a calibrated model) numeric IK on the robot seeded
    in each branch by the nominal model (``nominal``, default the robot's own nominal model, with
    this robot's base and tool: :func:`robocal.ik.numeric.nominal_branches`); branches it does not
    reach in their slot (by the nominal closed form) are NaN."""
    try:
        return solve_branches(robot, T)
    except ModelError:
        if is_scara_arm(robot):
            return _scara_branches(robot, T, nominal)
        form = branch_model(robot, nominal)
        if form is None:
            raise
    seeds = nominal_branches(robot, T, nominal)[0]
    flat = seeds.reshape(-1, robot.n_joints)
    ok = np.flatnonzero(np.isfinite(flat).all(axis=1))
    out = np.full(flat.shape, np.nan)
    if ok.size:
        res = ik_solve(robot, np.repeat(T, 8, axis=0)[ok], flat[ok], nominal=nominal)
        q = np.remainder(res.joints + np.pi, 2 * np.pi) - np.pi  # as the closed form: [-pi, pi)
        own = res.converged & (branch_slot(form, q) == ok % 8)  # a solution of another slot is that slot's
        out[ok[own]] = q[own]
    return out.reshape(seeds.shape)


def _scara_branches(robot: Robot, T: np.ndarray, nominal: Robot | None) -> np.ndarray:
    """A calibrated SCARA's 2 branches ``(M, 2, 4)``: the planar closed form of its own chain refined
    on its 4 tasks (:mod:`robocal.ik.scara`), kept where it converges in its own slot (the elbow's
    sign on ``nominal``, default the robot's nominal model)."""
    form = robot.nominal_robot() if nominal is None else nominal
    seeds = scara_ik.seed_branches(robot, T)
    M, B, n = seeds.shape
    q, err = scara_ik.refine(robot, np.repeat(T, B, axis=0), seeds.reshape(-1, n))
    q[:, [0, 1, 3]] = np.remainder(q[:, [0, 1, 3]] + np.pi, 2 * np.pi) - np.pi
    own = scara_ik.converged(err) & (scara_ik.branch_slot(form, q) == np.tile(np.arange(B), M))
    q[~own] = np.nan
    return q.reshape(M, B, n)


def plan_path(robot: Robot, poses, weights=None, start=None, nominal: Robot | None = None) -> PathResult:
    """The globally best joints along a whole path of TCP poses (Dijkstra over the IK branches).

    Per waypoint, the inverse-kinematics candidates inside the joint limits (the 8 closed-form
    branches and their +-2 pi copies) become the nodes of a layer; consecutive layers are joined
    by edges weighted by the weighted joint travel ``sum_i w_i |dq_i|``; the shortest path from the
    first layer to the last is the optimum over the whole trajectory.

    Parameters
    ----------
    robot : Robot
        The model (closed-form nominal models, or calibrated ones through their nominal's seeds).
    poses : array_like, shape (M, 4, 4)
        World TCP poses of the waypoints, metres.
    weights : array_like, shape (n,), optional
        Cost per radian of each joint; default `default_weights` (big joints cost more).
    start : array_like, shape (n,), optional
        A fixed starting configuration, radians, whose distance to the first waypoint counts.
    nominal : Robot, optional
        The controller's model whose closed form seeds a calibrated model's candidates.

    Returns
    -------
    PathResult
        The optimal ``joints`` (M, n) rad and their ``cost``, the greedy choice for comparison,
        the ``weights``, the branch ``slots`` and the candidate count per waypoint.

    Raises
    ------
    UnreachableError
        Waypoints without any candidate inside the limits, listed by index.
    DataError
        ``robot`` is an arm on a track (its path needs each pose's carriage position:
        `robocal.ik.track.plan`).

    See Also
    --------
    rc.ik.PathResult : What it returns.
    rc.ik.default_weights : The joints' default weights.
    rc.ik.solve_all : The solutions it chooses among.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> q = np.linspace([0.0, -0.3, 0.2, 0.0, 0.6, 0.0], [0.8, 0.1, 0.4, 0.5, 0.9, 1.0], 5)
    >>> path = rc.ik.plan_path(robot, robot.fk(q))
    >>> path.joints.shape, bool(path.cost <= path.greedy_cost)
    ((5, 6), True)
    """
    T = check_poses(poses)
    n = robot.n_joints
    if is_track_cell(robot):
        raise DataError(f"{robot.name} is an arm on a track: plan its path with each pose's carriage "
                        "position (robocal.ik.track.plan; in a poses CSV, an e1_mm column)")
    if n != _BRANCH_JOINTS and not is_scara_arm(robot):
        raise ModelError(
            f"plan chooses among the inverse-kinematics branches of a 6-joint arm; {robot.name} has {n} "
            "joints (" + ("redundant: infinitely many joint solutions per pose" if n > _BRANCH_JOINTS else
                          "fewer than 6: it cannot reach an arbitrary pose") +
            "), so there are no branches to choose from: plan its joint path in the robot's own software")
    w = default_weights(robot) if weights is None else check_weights(weights, n)
    if start is not None:
        start = np.asarray(start, dtype=float).reshape(-1)
        if start.shape != (n,) or not np.isfinite(start).all():
            raise DataError(f"start must be {n} finite joint values (rad), got {start.tolist()}")
    cand, src = turn_copies(robot, branch_candidates(robot, T, nominal))
    valid = src >= 0
    M, K, _ = cand.shape
    empty = np.flatnonzero(~valid.any(axis=1))
    if empty.size:
        raise UnreachableError(
            f"{empty.size} of {M} waypoint(s) have no IK solution inside the joint limits: indices "
            f"{empty[:30].tolist()}{' ...' if empty.size > 30 else ''}; move or drop them")
    node = 1 + np.arange(M * K).reshape(M, K)
    t_node = 1 + M * K
    rows, cols, data = [], [], []
    # S -> first layer: 1 (seed 001), or 1 + distance from the fixed start; without a start, paths
    # of equal travel (the same path shifted by whole turns on joints with more than a turn of
    # travel) are told apart by the first waypoint's distance from zero, scaled by _TIE_BREAK
    k0 = np.flatnonzero(valid[0])
    if start is None:
        c0 = 1.0 + _TIE_BREAK * (np.abs(cand[0, k0]) @ w)
    else:
        c0 = 1.0 + np.abs(cand[0, k0] - start) @ w
    rows.append(np.zeros(k0.size, int)), cols.append(node[0, k0]), data.append(c0)
    # layer m -> m + 1: every valid pair; +1 on every edge keeps zero-travel edges explicit and
    # shifts every S-T path by the same M - 1, so the optimum is unchanged
    step = max(1, _EDGE_CHUNK // (K * K))
    for s in range(0, M - 1, step):
        e = min(s + step, M - 1)
        cost = np.zeros((e - s, K, K))
        for i in range(n):  # per joint on (m, K, K) blocks: no 4-D temporary
            cost += w[i] * np.abs(cand[s:e, :, None, i] - cand[s + 1 : e + 1, None, :, i])
        ok = valid[s:e, :, None] & valid[s + 1 : e + 1, None, :]
        mi, ki, li = np.nonzero(ok)
        rows.append(node[s + mi, ki]), cols.append(node[s + mi + 1, li]), data.append(1.0 + cost[ok])
    kl = np.flatnonzero(valid[M - 1])
    rows.append(node[M - 1, kl]), cols.append(np.full(kl.size, t_node)), data.append(np.ones(kl.size))
    from scipy.sparse import csr_matrix  # here: every command imports robocal.ik, few plan paths
    from scipy.sparse.csgraph import dijkstra

    G = csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                   shape=(t_node + 1, t_node + 1))
    _, pred = dijkstra(G, directed=True, indices=0, return_predecessors=True)
    chosen = np.empty(M, int)
    v = pred[t_node]
    for m in range(M - 1, -1, -1):  # walk back from T: one node per layer
        chosen[m] = v - 1 - m * K
        v = pred[v]
    joints = cand[np.arange(M), chosen]
    if start is None:
        home = np.clip(np.zeros(n), robot.limits[:, 0], robot.limits[:, 1])
        first = cand[0, np.argmin(np.where(valid[0], np.abs(cand[0] - home) @ w, np.inf))]
    else:
        first = start
    greedy = _greedy(cand, valid, w, first)
    return PathResult(joints=joints, cost=travel(joints, w, start), greedy_joints=greedy,
                      greedy_cost=travel(greedy, w, start), weights=w,
                      slots=src[np.arange(M), chosen], candidates=valid.sum(axis=1), joint_specs=robot.joints)
