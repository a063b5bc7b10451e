"""Several kinds of measurement in one calibration (issue 17), on simulated truth.

1. A plane campaign (ABB IRB 2600, 3 planes, 60 contacts for calibration + 30 held out, probe
   noise 0.01 mm) with and without 8 placements of a 500 mm scale bar touched by the same probe
   (5 um): the calibrated probe tip against the truth up to a rigid motion over 300 random poses
   (what a user's absolute accuracy is once the frame is set), and the held-out contacts' distance
   to the calibrated planes against the probe noise.
2. Tracker points (60 poses, 0.02 mm) with and without a ball bar (40 pairs, 5 um): the true model
   error over 300 random poses.
"""

from __future__ import annotations

import numpy as np
from common import model_error_mm, rigid_error_mm
from results import table

import robocal as rc
from robocal.data.simulate import sample_joints, simulate_tracker

SEEDS = 5
ROBOT = rc.Robot.from_catalog("abb_irb2600")
PROBE_NOISE_MM = 0.01


def planes_and_scale_bar() -> None:
    rows = []
    for seed in range(SEEDS):
        sim = simulate_tracker(ROBOT, 90, kind="plane", n_planes=3, noise_mm=PROBE_NOISE_MM, seed=seed)
        cal, val = sim.data.subset(np.arange(60)), sim.data.subset(np.arange(60, 90))
        bar = simulate_tracker(sim.truth, 8, kind="distance", noise_mm=0.005, seed=100 + seed,
                               as_is=True).data
        start = ROBOT.with_frames(tool=sim.truth.tool.round(3))  # the probe as taught, to 1 mm
        q = sample_joints(sim.truth, 300, np.random.default_rng(1000 + seed))
        alone = rc.calibrate(start, cal, validation=val)
        both = rc.calibrate(start, [cal, bar], validation=val)
        floor = float(np.sqrt(np.mean(np.sum(sim.noise[60:90] ** 2, axis=1)))) * 1e3  # held-out noise
        row = [rigid_error_mm(start, sim.truth, q), rigid_error_mm(alone.robot, sim.truth, q),
               rigid_error_mm(both.robot, sim.truth, q), alone.validation["rms"] / PROBE_NOISE_MM,
               both.validation["rms"] / PROBE_NOISE_MM, alone.validation["rms"] / floor,
               both.validation["rms"] / floor]
        rows.append(row)
    table("plane campaign (3 planes, 60 contacts, probe noise 0.01 mm) + 8 placements of a 500 mm scale bar "
          "(5 um): probe tip vs truth after a rigid fit (mm), held-out plane deviation / probe noise and / "
          "the held-out contacts' own noise",
          ["seed", "tip, nominal", "tip, planes", "tip, planes + bar", "deviation / noise, planes",
           "/ noise, + bar", "/ floor, planes", "/ floor, + bar"],
          [[seed, *(f"{v:.4f}" for v in row[:3]), *(f"{v:.3f}" for v in row[3:])]
           for seed, row in enumerate(rows)])
    r = np.array(rows)
    print(f"range: tip + bar {r[:, 2].min():.4f}-{r[:, 2].max():.4f} mm (planes alone {r[:, 1].min():.4f}-"
          f"{r[:, 1].max():.4f}); held-out deviation + bar {r[:, 4].min():.3f}-{r[:, 4].max():.3f} x the "
          f"probe's sigma, {r[:, 6].min():.3f}-{r[:, 6].max():.3f} x the held-out contacts' own noise "
          "(goals: 0.08 mm, 1.35 x)")


def points_and_ball_bar() -> None:
    ratios, rows = [], []
    for seed in range(SEEDS):
        sim = simulate_tracker(ROBOT, 60, noise_mm=0.02, seed=seed)
        bar = simulate_tracker(sim.truth.with_frames(base=np.eye(4)), 40, kind="distance", noise_mm=0.005,
                               bar_length_m=0.8, seed=200 + seed, as_is=True).data
        q = sample_joints(sim.truth, 300, np.random.default_rng(2000 + seed))
        points = model_error_mm(rc.calibrate(ROBOT, sim.data).robot, sim.truth, q)
        both = model_error_mm(rc.calibrate(ROBOT, [sim.data, bar]).robot, sim.truth, q)
        ratios.append(both / points)
        rows.append([seed, f"{points:.4f}", f"{both:.4f}", f"{both / points:.3f}"])
    table("tracker points (60 poses, 0.02 mm) and a ball bar (40 pairs, 5 um): true model error over 300 "
          "random poses (mm)", ["seed", "points", "points + ball bar", "ratio"], rows)
    print(f"points + ball bar / points alone: {min(ratios):.3f}-{max(ratios):.3f}")


def main() -> None:
    planes_and_scale_bar()
    points_and_ball_bar()


if __name__ == "__main__":
    main()
