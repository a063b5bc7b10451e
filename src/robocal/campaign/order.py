"""The order in which to measure the chosen poses: short robot travel.

Travel between two poses is the weighted joint distance ``sum_i w_i |dq_i|`` of the seed-001
path planner (:func:`robocal.ik.path.default_weights`: the big joints cost more; ``dq`` in rad, a
prismatic joint's in m at weight 1 per metre, so that a metre along a track costs as much as a
radian of a wrist joint). The route is
an open path starting at the pose nearest the home position (zero joints, clipped into the
limits): nearest neighbour, then 2-opt (reverse any stretch of the route that shortens it)
until no reversal helps.
"""

from __future__ import annotations

import numpy as np

TWO_OPT_RTOL = 1e-12  # a reversal must shorten the route by more than this (relative)


def _distances(q: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``(N, N)`` weighted joint distances."""
    return np.abs(q[:, None, :] - q[None, :, :]) @ weights


def _nearest_neighbour(D: np.ndarray, first: int) -> np.ndarray:
    N = len(D)
    route = [first]
    free = np.ones(N, bool)
    free[first] = False
    for _ in range(N - 1):  # sequential by nature: each step starts where the last ended
        d = np.where(free, D[route[-1]], np.inf)
        nxt = int(np.argmin(d))
        route.append(nxt)
        free[nxt] = False
    return np.array(route)


def _two_opt(route: np.ndarray, D: np.ndarray) -> np.ndarray:
    """Open-path 2-opt with the first pose fixed: reversing ``route[i:j+1]`` replaces the edges
    (i-1, i) and (j, j+1) by (i-1, j) and (i, j+1) (no edge after the last pose)."""
    route = route.copy()
    N = len(route)
    improved = True
    while improved:
        improved = False
        for i in range(1, N - 1):
            a, b = route[i - 1], route[i]
            j = np.arange(i + 1, N)
            c = route[j]
            nxt = np.where(j + 1 < N, route[np.minimum(j + 1, N - 1)], -1)
            old = D[a, b] + np.where(nxt >= 0, D[c, np.maximum(nxt, 0)], 0.0)
            new = D[a, c] + np.where(nxt >= 0, D[b, np.maximum(nxt, 0)], 0.0)
            gain = old - new
            k = int(np.argmax(gain))
            if gain[k] > TWO_OPT_RTOL * max(D[a, b], 1e-300):
                route[i : j[k] + 1] = route[i : j[k] + 1][::-1]
                improved = True
    return route


def measuring_order(robot, q: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Permutation ``(N,)`` of joints ``q (N, n)`` (rad; m on a prismatic joint) giving a short
    measuring route."""
    if len(q) < 2:
        return np.arange(len(q))
    D = _distances(q, weights)
    home = np.clip(np.zeros(robot.n_joints), robot.limits[:, 0], robot.limits[:, 1])
    first = int(np.argmin(np.abs(q - home) @ weights))
    return _two_opt(_nearest_neighbour(D, first), D)

