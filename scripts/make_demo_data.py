"""Regenerate the demo campaign shipped in src/robocal/demo_data (deterministic: fixed seed).

A simulated laser-tracker campaign on the catalog ABB IRB 2600: 300 poses, isotropic noise
0.02 mm, 5% gross outliers of 1-5 mm. Poses 0-99 (outliers included) are the calibration set;
the outlier-free rows of poses 100-299 are the validation set. The truth model is kept so the
demo can show how far the calibrated model is from it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal import Robot
from robocal.data.simulate import simulate_tracker

OUT = Path(__file__).resolve().parents[1] / "src" / "robocal" / "demo_data"


def main() -> None:
    sim = simulate_tracker(Robot.from_catalog("abb_irb2600"), 300, noise_mm=0.02, outliers=0.05, seed=2026)
    data = sim.data
    clean = ~np.isin(np.arange(len(data)), sim.outlier_rows)
    data.subset(np.flatnonzero(data.pose_id < 100)).save(OUT / "calibration.csv")
    data.subset(np.flatnonzero((data.pose_id >= 100) & clean)).save(OUT / "validation.csv")
    sim.truth.save(OUT / "truth.yaml")
    print(f"wrote {OUT}: noise floor {sim.noise_floor_mm:.4f} mm, {len(sim.outlier_rows)} outliers")


if __name__ == "__main__":
    main()
