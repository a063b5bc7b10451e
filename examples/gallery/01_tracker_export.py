"""A calibration from a laser-tracker export
===========================================

A tracker's software exports what it measured as a plain table: no header, the six joint angles
the controller reported (degrees) and the SMR's position (millimetres), one row per reading, and
several readings of each pose; a reading may have failed (zeros) and a pose may carry a gross
error (an SMR knocked in its nest). This example writes such an export for an ABB IRB 2600 whose
true geometry we know (simulated, fixed seed), imports it, calibrates the robot robustly on 60
poses, judges the result on 30 held-out poses, and compares the calibrated model with the true
robot.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import robocal as rc
from robocal.data.importer import import_tracker

# %% The robot and a campaign: 90 poses of a robot with unknown errors
nominal = rc.Robot.from_catalog("abb_irb2600")
sim = rc.simulate_tracker(nominal, 90, noise_mm=0.02, outliers=0.05, seed=7)
truth = sim.truth  # the true robot (tracker frame as base): what the calibration must find
print(f"{len(sim.outlier_rows)} poses got a gross error of 1-5 mm (a bumped SMR, say)")

# %% The export: 3 readings per pose, joints in deg, points in mm, one failed reading
rng = np.random.default_rng(7)
joints_deg = np.repeat(np.rad2deg(sim.data.joints), 3, axis=0)
points_mm = np.repeat(sim.data.points * 1e3, 3, axis=0)
points_mm += rng.normal(0, 0.005, points_mm.shape)  # each reading's own noise
points_mm[10] = 0.0  # the tracker lost the beam on this reading
export = Path("irb2600_export.txt")
np.savetxt(export, np.hstack([joints_deg, points_mm]), fmt="%.6f", delimiter=";")

# %% Import: which columns hold what, in which unit; repeated readings are averaged
imported = import_tracker([export], joints="cols=0-5:deg", points="cols=6-8:mm")
print(imported.summary())
calibration, validation = imported.data.split_poses(60)

# %% Calibrate (robust: a gross error is down-weighted) and judge on held-out poses
result = rc.calibrate(nominal, calibration, method="robust", validation=validation,
                      progress=False)
inliers = result.after_inliers or result.after
print(f"\ncalibration RMS {result.before['rms']:.3f} mm -> {inliers['rms']:.3f} mm "
      f"without the {len(result.rejected)} rejected observations")
print(f"validation  RMS {result.validation_before['rms']:.3f} mm -> "
      f"{result.validation['rms']:.3f} mm")

# %% Against the truth: the calibrated model's flange on the validation poses
q = validation.joints
gap_mm = np.linalg.norm(result.robot.fk(q)[:, :3, 3] - truth.fk(q)[:, :3, 3], axis=1) * 1e3
print(f"calibrated model vs true robot: RMS {np.sqrt(np.mean(gap_mm**2)):.4f} mm, "
      f"max {gap_mm.max():.4f} mm")

# %% Figure: the error of each held-out pose with the nominal and the calibrated model
before, after = (e * 1e3 for e in result.judged[0].errors)  # (30,) m -> mm, one per pose
fig, ax = plt.subplots(figsize=(5, 3), layout="constrained")
ax.bar(np.arange(len(before)) - 0.2, before, 0.4, label="nominal model")
ax.bar(np.arange(len(after)) + 0.2, after, 0.4, label="calibrated model")
ax.set(xlabel="validation pose", ylabel="position error, mm", yscale="log",
       title="IRB 2600: held-out poses before and after")
ax.legend()
fig.savefig("01_tracker_export.png", dpi=120)
