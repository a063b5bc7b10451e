"""Seed-001 joint path: Dijkstra optimum equals brute-force DP and exhaustive enumeration."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError, UnreachableError
from robocal.ik import solve_all
from robocal.ik.path import default_weights, travel


def trajectory(robot, M, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, M)[:, None]
    a = rng.uniform(0.2, 0.8, 6)
    f = rng.integers(1, 4, 6)
    q = np.clip(a * np.sin(2 * np.pi * f * t + rng.uniform(0, 6, 6)), robot.limits[:, 0], robot.limits[:, 1])
    return robot.fk(q)


def dp_optimum(cand, w, start=None):
    """Brute-force dynamic programming over the layers (loops; independent of the graph)."""
    valid = np.isfinite(cand).all(axis=2)
    best = np.where(valid[0], 0.0 if start is None else np.abs(cand[0] - start) @ w, np.inf)
    for m in range(1, len(cand)):
        step = np.array([[np.abs(cand[m, j] - cand[m - 1, i]) @ w for i in range(cand.shape[1])]
                         for j in range(cand.shape[1])])  # (K new, K old)
        step = np.where(np.isnan(step), np.inf, step)
        best = np.where(valid[m], np.min(best[None, :] + step, axis=1), np.inf)
    return best.min()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_equals_dynamic_programming(seed):
    robot = rc.Robot.from_catalog("abb_irb2600")
    T = trajectory(robot, 60, seed)
    res = rc.ik.plan_path(robot, T)
    cand = solve_all(robot, T, extra_turns=True)
    assert res.cost == pytest.approx(dp_optimum(cand, res.weights), abs=1e-9)
    assert res.cost <= res.greedy_cost + 1e-12
    assert res.cost == pytest.approx(travel(res.joints, res.weights))
    e = rc.ik.solve(robot, T, res.joints)  # chosen joints reach the poses
    assert e.position_error.max() < 1e-9 and robot.within_limits(res.joints).all()
    start = np.array([0.1, 0.2, -0.1, 3.0, 0.5, -2.0])
    res_s = rc.ik.plan_path(robot, T, start=start)
    assert res_s.cost == pytest.approx(dp_optimum(cand, res_s.weights, start), abs=1e-9)


def test_exhaustive_tiny():
    robot = rc.Robot.from_catalog("kuka_kr6_r700")
    T = trajectory(robot, 4, 5)
    w = np.array([3.0, 2.5, 2.0, 1.0, 0.7, 0.5])
    res = rc.ik.plan_path(robot, T, weights=w)
    cand = solve_all(robot, T, extra_turns=True)
    layers = [c[np.isfinite(c).all(axis=1)] for c in cand]
    brute = min(travel(np.array(combo), w) for combo in itertools.product(*layers))
    assert res.cost == pytest.approx(brute, abs=1e-12)


def test_repeated_waypoints_cost_zero():
    robot = rc.Robot.from_catalog("abb_irb2600")
    T = np.repeat(trajectory(robot, 1), 5, axis=0)
    res = rc.ik.plan_path(robot, T)
    assert res.cost == 0.0 and np.ptp(res.joints, axis=0).max() == 0.0


def test_optimal_beats_greedy_somewhere():
    robot = rc.Robot.from_catalog("abb_irb2600")
    gains = [rc.ik.plan_path(robot, trajectory(robot, 40, s)) for s in range(6)]
    assert all(g.cost <= g.greedy_cost + 1e-12 for g in gains)


def test_default_weights_big_joints_cost_more():
    w = default_weights(rc.Robot.from_catalog("abb_irb2600"))
    assert (w[:3] > 1.5).all() and (w[3:] == 1).all()


def test_bad_input():
    robot = rc.Robot.from_catalog("abb_irb2600")
    T = trajectory(robot, 5)
    T[[1, 3], :3, 3] += 5.0  # out of reach
    with pytest.raises(UnreachableError, match=r"\[1, 3\]"):
        rc.ik.plan_path(robot, T)
    T = trajectory(robot, 5)
    with pytest.raises(DataError, match="6 values"):
        rc.ik.plan_path(robot, T, weights=[1, 1, 1])
    with pytest.raises(DataError, match=">= 0"):
        rc.ik.plan_path(robot, T, weights=[1, 1, 1, 1, -1, 1])
    with pytest.raises(DataError, match="start"):
        rc.ik.plan_path(robot, T, start=[0, 0])


def test_cli_plan(tmp_path, capsys):
    robot = rc.Robot.from_catalog("abb_irb2600")
    T = trajectory(robot, 20)
    from robocal.deploy.compensation import format_csv, pose_columns

    cols, vals = pose_columns(T, {"length": "mm", "orientation": "deg"})
    (tmp_path / "poses.csv").write_text(format_csv(cols, vals))
    out = tmp_path / "joints.csv"
    assert main(["plan", "--robot", "abb_irb2600", str(tmp_path / "poses.csv"), "--start",
                 "0,0,0,0,30,0", "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "optimal total weighted travel" in printed and "greedy" in printed
    q = np.deg2rad(np.loadtxt(out, delimiter=",", skiprows=1))
    res = rc.ik.plan_path(robot, T, start=np.deg2rad([0, 0, 0, 0, 30, 0]))
    assert np.allclose(q, res.joints, atol=1e-9)
    assert main(["plan", "--robot", "abb_irb2600", str(tmp_path / "poses.csv"), "--weights", "1,2",
                 "-o", str(out)]) == 2
