"""Simulations of real campaigns held back from the project (issue 20), shared by
tests/test_priors.py and benchmarks/bench_priors.py: a UR5 with the SMR on the flange axis on a
joint grid with gear and cyclic errors, and a 7-axis arm from a standard DH table with unmodelled
joint coupling. Each returns the nominal robot, calibration and validation Measurements (and the
UR5 its SimulationResult, for the noise floor)."""

from dataclasses import replace

import numpy as np

import robocal as rc
from robocal.data.simulate import simulate_tracker

UR_TERMS = ["gear2_s1", "gear2_c1", "gear3_s1", "gear3_c1", "cyc2_101_s", "cyc2_101_c", "cyc3_101_s",
            "cyc3_101_c"]
UR_VALUES = np.deg2rad([0.01, -0.008, 0.012, 0.006, 0.004, -0.003, 0.003, 0.004])


def ur5_campaign(n=1000, n_val=200, seed=0):
    """A UR5 on a 15-deg joint grid, the SMR 34 mm out on the flange axis, gear and cyclic errors."""
    nominal = rc.Robot.from_catalog("ur5")
    rng = np.random.default_rng(seed)
    q = rng.choice(np.deg2rad(np.arange(-165, 166, 15)), (n + n_val, 6))
    true = nominal.with_joint_errors(UR_TERMS).with_values(dict(zip(UR_TERMS, UR_VALUES, strict=True)))
    sim = simulate_tracker(true, joints=q, smr_offsets=[[0, 0, 0.034]], noise_mm=0.02, seed=seed)
    return nominal, sim.data.subset(sim.data.pose_id < n), sim.data.subset(sim.data.pose_id >= n), sim


def seven_axis_campaign(n=216, n_val=100, seed=0):
    """A Barrett-WAM-like 7-axis arm (standard DH), 4x the simulator's geometric errors, joints over
    30 % of their ranges, and 0.3 deg of joint coupling no robocal term models (a few mm)."""
    robot = rc.Robot.from_dh([0] * 7, [0, 0, 0.55, 0, 0.3, 0, 0.06], [0, 0, 0.045, -0.045, 0, 0, 0],
                             [-90, 90, -90, 90, -90, 90, 0], degrees=True, name="wam",
                             limits=[[-150, 150], [-113, 113], [-157, 157], [-50, 180], [-275, 75],
                                     [-90, 90], [-172, 172]])
    rng = np.random.default_rng(seed)
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    mid, half = (lo + hi) / 2, 0.3 * (hi - lo) / 2
    q = rng.uniform(mid - half, mid + half, (n + n_val, 7))
    dq = np.deg2rad(0.3) * np.sin(np.roll(q, 1, axis=1) + 0.7 * np.roll(q, -1, axis=1) + np.arange(7))
    sim = simulate_tracker(robot, joints=q + dq, smr_offsets=[[0, 0, 0.05]], noise_mm=0.05, seed=seed,
                           error_scale=4.0)
    data = replace(sim.data, joints=sim.data.joints - dq[sim.data.pose_id])  # the commanded joints
    return robot, data.subset(data.pose_id < n), data.subset(data.pose_id >= n)
