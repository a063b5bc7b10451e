"""A robot on a linear track: a simulated KUKA KR 210 R2700 on a 6 m track (track tilt 0.04 deg,
encoder scale 2e-4, mount 1 mm / 0.05 deg, arm errors, 0.02 mm tracker noise) calibrated from 200
poses spread along the track and judged on 200 held-out poses (their own noise floor: the RMS of
the noise added to them). Goal: held-out RMS <= 1.3 x the noise floor.

``python benchmarks/bench_track.py``."""

from __future__ import annotations

import numpy as np
from results import figure, table

from robocal.calibration import calibrate
from robocal.data.simulate import simulate_tracker
from robocal.evaluate import evaluate
from robocal.kinematics.cell import TRACK_SCALE, cell_from_data

CELL = {"units": {"length": "mm", "angle": "deg"}, "name": "kr210 on a 6 m track",
        "robot": "kuka_kr210_r2700", "track": {"direction": [1, 0, 0], "limits": [0, 6000]},
        "mount": {"xyz": [0, 0, 0], "rpy": [0, 0, 0]}}
SEEDS = range(5)
N_CAL, N_VAL = 200, 200


def main() -> None:
    cell = cell_from_data(CELL)
    rows, ratios = [], []
    for seed in SEEDS:
        sim = simulate_tracker(cell, N_CAL + N_VAL, noise_mm=0.02, seed=seed)
        cal, val = sim.data.first_poses(N_CAL), sim.data.subset(np.arange(N_CAL, N_CAL + N_VAL))
        floor = float(np.sqrt(np.mean(np.sum(sim.noise[N_CAL:] ** 2, axis=1)))) * 1e3
        before = evaluate(cell, val, fit_frame=True)["rms"]
        result = calibrate(cell, cal)
        after = evaluate(result.robot, val)["rms"]
        ratios.append(after / floor)
        scales = [f"{r.get(TRACK_SCALE) * 1e6:+.1f}" for r in (sim.truth, result.robot)]
        rows.append([seed, f"{before:.3f}", f"{floor:.4f}", f"{after:.4f}", f"{after / floor:.2f}", *scales])
    table("KR 210 R2700 on a 6 m track: 200 calibration poses, 200 held out (mm)",
          ["seed", "nominal RMS", "noise floor", "held-out RMS", "ratio", "scale truth ppm",
           "scale est. ppm"], rows, key="kr210")
    print("  worst ratio:", figure("worst_ratio", f"{max(ratios):.2f}"))


if __name__ == "__main__":
    main()
