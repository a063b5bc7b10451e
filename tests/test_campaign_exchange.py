"""The exchange search against brute force, its Woodbury scans against direct computation, and
the measuring order."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from robocal import Robot
from robocal.campaign.constraints import conflict_rows
from robocal.campaign.exchange import _Design, criterion_value, exchange_search
from robocal.campaign.order import _distances, _nearest_neighbour, measuring_order
from robocal.ik.path import default_weights, travel


def _problem(seed: int, C: int = 11, r: int = 3, p: int = 6):
    rng = np.random.default_rng(seed)
    G = rng.standard_normal((C, r, p)) * rng.uniform(0.2, 2.0, (C, 1, 1))
    L = rng.standard_normal((p, p))
    return G, L @ L.T / p


def _brute(G, A, n, criterion, allowed=lambda combo: True):
    best = (np.inf, None)
    for combo in itertools.combinations(range(len(G)), n):
        if allowed(combo):
            v = criterion_value(G, A, combo, criterion)
            best = min(best, (v, combo), key=lambda t: t[0])
    return best


@pytest.mark.parametrize("criterion", ["I", "D", "O4"])
@pytest.mark.parametrize("seed", range(5))
def test_exchange_finds_the_brute_force_optimum(criterion, seed):
    G, A = _problem(seed, r=1 + seed % 3, p=4 + seed % 2)
    n = 5
    best_value, best_combo = _brute(G, A, n, criterion)
    found = exchange_search(G, A, n, criterion=criterion, starts=4, seed=seed)
    assert found.value == pytest.approx(best_value, rel=1e-8)
    assert found.value == pytest.approx(criterion_value(G, A, found.indices, criterion), rel=1e-12)
    assert sorted(found.indices.tolist()) == sorted(best_combo) or found.value <= best_value * (1 + 1e-8)


@pytest.mark.parametrize("seed", range(3))
def test_exchange_with_a_minimum_distance_finds_the_feasible_optimum(seed):
    G, A = _problem(10 + seed, C=12)
    q = np.deg2rad(np.random.default_rng(seed).uniform(0, 60, (12, 2)))
    d_min = 15.0
    conflicts = conflict_rows(q, d_min)
    qd = np.rad2deg(q)

    def feasible(combo):
        return all(np.linalg.norm(qd[a] - qd[b]) >= d_min for a, b in itertools.combinations(combo, 2))

    best_value, _ = _brute(G, A, 4, "I", feasible)
    found = exchange_search(G, A, 4, criterion="I", starts=6, seed=seed, conflicts=conflicts)
    assert feasible(found.indices)
    assert found.value == pytest.approx(best_value, rel=1e-8)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), r=st.integers(1, 4), p=st.integers(2, 7), criterion=st.sampled_from("ID"))
@example(seed=1, r=1, p=7, criterion="I")  # a removal with leverage near 1
def test_woodbury_scans_equal_direct_computation(seed, r, p, criterion):
    rng = np.random.default_rng(seed)
    C = 30
    G = rng.standard_normal((C, r, p))
    A = rng.standard_normal((p, p))
    A = A @ A.T
    members = list(range(p + 3))
    design = _Design(G, A, criterion, conflict_rows(np.zeros((C, 1)), 0.0))
    design.reset(members)
    for _ in range(15):  # a walk of incremental exchanges, then compare with direct computation
        j = int(rng.integers(C))
        if j not in design.members:
            design.add(j)
            design.remove(design.members[int(rng.integers(len(design.members) - 1))])
    added = design.add_values(np.ones(C, bool))
    removed = design.remove_values()
    direct_add = [criterion_value(G, A, design.members + [j], criterion) for j in range(C)]
    direct_remove = [criterion_value(G, A, [m for m in design.members if m != i], criterion)
                     for i in design.members]
    for j in range(C):
        if j not in design.members:
            assert added[j] == pytest.approx(direct_add[j], rel=1e-6, abs=1e-6)
    # a removal that nearly loses rank (leverage near 1) amplifies the updates' rounding by
    # 1 / lambda_min(I - G_m M^-1 G_m^T): the tolerance carries that condition number
    Minv = np.linalg.inv(sum(G[m].T @ G[m] for m in design.members))
    amplification = [1.0 / np.linalg.eigvalsh(np.eye(r) - G[m] @ Minv @ G[m].T)[0] for m in design.members]
    np.testing.assert_array_less(np.abs(np.subtract(removed, direct_remove)),
                                 1e-6 * np.maximum(amplification, 1.0) * (np.abs(direct_remove) + 1.0))
    assert design.value == pytest.approx(criterion_value(G, A, design.members, criterion), rel=1e-6, abs=1e-6)


def test_exchange_is_deterministic_and_starts_from_a_given_design():
    G, A = _problem(3, C=40, p=8)
    a = exchange_search(G, A, 6, seed=7)
    b = exchange_search(G, A, 6, seed=7)
    np.testing.assert_array_equal(a.indices, b.indices)
    warm = exchange_search(G, A, 9, init=a.indices)
    assert set(a.indices) <= set(range(40)) and len(warm.indices) == 9
    assert warm.value <= a.value  # more poses never predict worse


def test_measuring_order_is_2opt_optimal_and_short():
    robot = Robot.from_catalog("abb_irb2600")
    rng = np.random.default_rng(4)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (25, 6))
    w = default_weights(robot)
    order = measuring_order(robot, q, w)
    assert sorted(order.tolist()) == list(range(25))
    D = _distances(q, w)
    route = order
    length = travel(q[route], w)
    assert length <= travel(q[_nearest_neighbour(D, route[0])], w) + 1e-9
    assert length < travel(q, w)
    for i in range(1, 24):  # no reversal of a stretch shortens the route
        for j in range(i + 1, 25):
            alt = route.copy()
            alt[i : j + 1] = alt[i : j + 1][::-1]
            assert travel(q[alt], w) >= length - 1e-9


def test_measuring_order_on_tiny_sets_matches_brute_force_or_is_close():
    robot = Robot.from_catalog("meca500")
    rng = np.random.default_rng(5)
    w = default_weights(robot)
    for _ in range(5):
        q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (6, 6))
        order = measuring_order(robot, q, w)
        best = min(travel(q[list(p)], w) for p in itertools.permutations(range(6)) if p[0] == order[0])
        assert travel(q[order], w) <= 1.15 * best
