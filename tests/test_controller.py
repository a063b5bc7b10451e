"""The controller's own branch choice (nearest closed-form solution to the previous joints), used
by compensate, plan (seed 001 on UR arms) and filter."""

from __future__ import annotations

import numpy as np
import pytest
from robots import wrapped

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.deploy.compensation import compensate
from robocal.ik import solve_all
from robocal.ik.closed_form import branch_slot
from robocal.ik.controller import nearest_solutions
from robocal.ik.singularity import singularity_distance


def walk(robot, M, step_deg, seed):
    """Joints ``(M, 6)`` of a random walk inside the limits, every joint moving at most step_deg."""
    rng = np.random.default_rng(seed)
    lo, hi = robot.limits[:, 0] * 0.8, robot.limits[:, 1] * 0.8
    q = np.empty((M, 6))
    q[0] = rng.uniform(np.maximum(lo, -np.pi), np.minimum(hi, np.pi))
    for m in range(1, M):
        q[m] = np.clip(q[m - 1] + np.deg2rad(rng.uniform(-step_deg, step_deg, 6)), lo, hi)
    return q


@pytest.mark.parametrize("name", ["ur5", "ur10e", "ur20", "abb_irb2600", "kuka_kr16_2"])
def test_follows_a_taught_path(name):
    """Targets taught by moving each joint at most 12 deg: the controller stays on the taught
    joints, whatever branch they are on, except within a few mm / deg of a singularity, where
    another solution is as near (there it takes one no farther than the taught one)."""
    robot = rc.Robot.from_catalog(name)
    q = walk(robot, 200, 12.0, 1)
    choice = nearest_solutions(robot, robot.fk(q), q[0])
    assert choice.jumps.size == 0 and choice.unreachable.size == 0
    other = np.abs(choice.joints - q).max(axis=1) > 1e-7
    far = singularity_distance(robot, q)
    near = (far.shoulder_mm < 20) | (far.elbow_deg < 6) | (far.wrist_deg < 6)
    assert not (other & ~near).any() and other.mean() < 0.05
    prev = np.vstack([q[:1], choice.joints[:-1]])
    for i in np.flatnonzero(other):
        assert ((choice.joints[i] - prev[i]) ** 2).sum() <= ((q[i] - prev[i]) ** 2).sum() + 1e-12
    ok = ~other
    assert (choice.slots[ok] == branch_slot(robot, q[ok])).all()


def test_equals_brute_force_nearest():
    """Each choice is the candidate nearest the previous one among every solution inside the limits
    (brute force over solve_all's candidates, one target at a time)."""
    robot = rc.Robot.from_catalog("ur5e")
    rng = np.random.default_rng(3)
    q = rng.uniform(-np.pi, np.pi, (60, 6))
    T = robot.fk(q)
    start = rng.uniform(-2, 2, 6)
    choice = nearest_solutions(robot, T, start)
    prev = start
    for i in range(len(T)):
        cand = solve_all(robot, T[i:i + 1], extra_turns=True)[0]
        cand = cand[np.isfinite(cand).all(axis=1)]
        best = cand[np.argmin(((cand - prev) ** 2).sum(axis=1))]
        np.testing.assert_allclose(choice.joints[i], best, atol=1e-9)
        prev = best


def test_agrees_with_the_nearest_of_ur_analytic_ik_solutions():
    """The candidates from independent code: every solution ur-analytic-ik returns, with its +-2 pi
    copies inside the limits; the nearest of them is the controller's choice. (The peer's own
    inverse_kinematics_closest is not the nearest solution: it returned one 36 rad^2 away where
    one 12 rad^2 away exists, so it is not used.)"""
    peer = pytest.importorskip("ur_analytic_ik", reason="ur-analytic-ik (test extra) not installed")
    robot = rc.Robot.from_catalog("ur5e")
    rng = np.random.default_rng(4)
    q = rng.uniform(-np.pi, np.pi, (300, 6))
    prev = rng.uniform(-3.5, 3.5, (300, 6))
    prev[:, 2] = rng.uniform(-3.0, 3.0, 300)  # the UR5e elbow: +-180 deg
    T = robot.fk(q)
    shifts = np.array(np.meshgrid(*[[-2 * np.pi, 0.0, 2 * np.pi]] * 6, indexing="ij")).reshape(6, -1).T
    for i in range(300):
        sols = np.array(peer.ur5e.inverse_kinematics(T[i]))
        cand = (sols[:, None, :] + shifts[None]).reshape(-1, 6)
        cand = cand[robot.within_limits(cand)]
        best = cand[np.argmin(((cand - prev[i]) ** 2).sum(axis=1))]
        ours = nearest_solutions(robot, T[i:i + 1], prev[i]).joints[0]
        np.testing.assert_allclose(ours, best, atol=1e-7)


def test_jumps_and_unreachable_are_reported():
    robot = rc.Robot.from_catalog("ur5")
    q = walk(robot, 10, 5.0, 2)
    T = robot.fk(q)
    T[4, :3, 3] += 5.0  # 5 m away
    choice = nearest_solutions(robot, T, q[0], anchors=None, jump_deg=3.0)
    assert choice.unreachable.tolist() == [4] and np.isnan(choice.joints[4]).all()
    np.testing.assert_allclose(np.delete(choice.joints, 4, axis=0), np.delete(q, 4, axis=0), atol=1e-7)
    assert set(choice.jumps.tolist()) == {i for i in range(1, 10) if i != 4 and np.rad2deg(
        np.abs(q[i] - q[i - 1 if i != 5 else 3]).max()) > 3.0}
    with pytest.raises(DataError, match="start"):
        nearest_solutions(robot, T, q[0, :5])


def test_anchor_replaces_the_previous_joints():
    robot = rc.Robot.from_catalog("ur10e")
    q = walk(robot, 6, 5.0, 3)
    T = robot.fk(q)
    other = solve_all(robot, T[3:4])[0]
    far = other[np.argmax(np.abs(wrapped(other - q[3])).max(axis=1))]  # another branch of target 3
    anchors = np.full((6, 6), np.nan)
    anchors[3] = far
    choice = nearest_solutions(robot, T, q[0], anchors)
    np.testing.assert_allclose(choice.joints[:3], q[:3], atol=1e-7)
    assert np.abs(wrapped(choice.joints[3] - far)).max() < 1e-7


def test_compensate_takes_the_controllers_branch():
    """compensate(start=...) seeds each target with the controller's choice: the calibrated joints
    stay on the taught branch, and reach the targets on the calibrated model."""
    nominal = rc.Robot.from_catalog("ur5e")
    cal = perturbed(nominal, 5)
    q = walk(nominal, 80, 12.0, 4)
    T = cal.fk(q)
    res = compensate(cal, nominal, T, start=q[0])
    assert res.converged.all()
    far = singularity_distance(nominal, q)
    clear = (far.shoulder_mm > 20) & (far.elbow_deg > 6) & (far.wrist_deg > 6)  # see test_follows_...
    assert clear.mean() > 0.8
    np.testing.assert_allclose(res.joints[clear], q[clear], atol=1e-6)
    assert (branch_slot(nominal, res.joints[clear]) == branch_slot(nominal, q[clear])).all()
    with pytest.raises(DataError, match="one of"):
        compensate(cal, nominal, T, start=q[0], branch=0)


def test_plan_path_on_a_ur_equals_dynamic_programming():
    """Seed 001 on a UR: the 8 closed-form branches (with turn copies) per waypoint, Dijkstra's
    optimum equals a dynamic programme over the same candidates."""
    robot = rc.Robot.from_catalog("ur5e")
    q = walk(robot, 8, 20.0, 5)
    T = robot.fk(q)
    res = rc.ik.plan_path(robot, T)
    cand = solve_all(robot, T, extra_turns=True)
    valid = np.isfinite(cand).all(axis=2)
    best = np.where(valid[0], 0.0, np.inf)
    for m in range(1, len(cand)):
        step = np.abs(cand[m][:, None, :] - cand[m - 1][None, :, :]) @ res.weights  # (new, old)
        best = np.where(valid[m], np.min(best[None, :] + np.where(np.isnan(step), np.inf, step), axis=1),
                        np.inf)
    assert res.cost == pytest.approx(best.min(), abs=1e-9)
    assert robot.within_limits(res.joints).all()
    np.testing.assert_allclose(robot.fk(res.joints), T, atol=1e-9)


def test_cli_compensate_start(tmp_path, capsys):
    nominal = rc.Robot.from_catalog("ur5")
    cal = perturbed(nominal, 6)
    q = walk(nominal, 20, 10.0, 6)
    T = cal.fk(q)
    cal_path = tmp_path / "cal.yaml"
    cal.save(cal_path)
    from scipy.spatial.transform import Rotation
    quat = Rotation.from_matrix(T[:, :3, :3]).as_quat(scalar_first=True)
    rows = ["x_mm,y_mm,z_mm,qw,qx,qy,qz"]
    rows += [",".join(repr(float(v)) for v in (*(T[i, :3, 3] * 1e3), *quat[i])) for i in range(20)]
    (tmp_path / "targets.csv").write_text("\n".join(rows) + "\n")
    start = ",".join(f"{v:.12f}" for v in np.rad2deg(q[0]))
    out = tmp_path / "commands.csv"
    assert main(["compensate", str(cal_path), str(tmp_path / "targets.csv"), "--nominal", "ur5",
                 "--start", start, "-o", str(out)]) == 0
    got = np.loadtxt(out, delimiter=",", skiprows=2, usecols=range(6))  # marker, header
    np.testing.assert_allclose(np.deg2rad(got), compensate(cal, nominal, T, start=q[0]).joints, atol=1e-9)
    assert main(["compensate", str(cal_path), str(tmp_path / "targets.csv"), "--nominal", "ur5",
                 "--start", "1,2,3", "-o", str(tmp_path / "c2.csv")]) == 2
    assert "start" in capsys.readouterr().err
