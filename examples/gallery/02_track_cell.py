"""A robot on a linear track
==========================

A KUKA KR 210 rides a 6 m track: the cell is a 7-joint chain whose first joint is the carriage
position e1 (metres). The track has errors of its own (its direction tilts, its encoder scale is
off by a few hundred ppm, the arm sits on the carriage not quite where the drawing says), and they
grow along the track. Calibrating the arm and the track together on poses spread along the whole
track removes both. The data are simulated from a cell with known errors (fixed seed).
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import robocal as rc
from robocal.kinematics.cell_file import TRACK_SCALE

# %% The cell file: the arm (a catalog name), the track's direction and range, the mount
Path("track.yaml").write_text("""\
units: {length: mm, angle: deg}
name: kr210 on a 6 m track
robot: kuka_kr210_r2700
track: {direction: [1, 0, 0], limits: [0, 6000]}
mount: {xyz: [0, 0, 0], rpy: [0, 0, 0]}
""")
cell = rc.Robot.load("track.yaml")
print(f"{cell.name}: {cell.n_joints} joints (e1, then q1..q6)")

# %% A campaign along the track: 160 poses to calibrate, 80 held out
sim = rc.simulate_tracker(cell, 240, noise_mm=0.02, seed=4)
calibration, validation = sim.data.first_poses(160), sim.data.subset(np.arange(160, 240))
e1 = validation.joints[:, 0]  # m: the carriage position of each held-out pose
print(f"held-out carriage positions {e1.min():.2f} .. {e1.max():.2f} m")

# %% Calibrate the arm and the track together (geometry only)
result = rc.calibrate(cell, calibration, validation=[validation], nongeometric="none",
                      progress=False)
found, true = result.robot.get(TRACK_SCALE) * 1e6, sim.truth.get(TRACK_SCALE) * 1e6
print(f"track encoder scale error: found {found:+.1f} ppm, true {true:+.1f} ppm")

# %% Held-out poses, each judged in its own tracker frame without refitting the model
nominal = rc.evaluate(cell, validation, fit_frame=True)
calibrated = rc.evaluate(result.robot, validation)
print(f"validation RMS: nominal {nominal['rms']:.3f} mm, "
      f"calibrated {calibrated['rms']:.4f} mm (noise floor {sim.noise_floor_mm:.4f} mm)")

# %% Figure: the held-out error along the track, before and after
before, after = (e * 1e3 for e in result.judged[0].errors)
fig, ax = plt.subplots(figsize=(5, 3), layout="constrained")
ax.scatter(e1, before, s=12, label="nominal cell")
ax.scatter(e1, after, s=12, label="calibrated cell")
ax.set(xlabel="carriage position e1, m", ylabel="position error, mm", yscale="log",
       title="KR 210 on a 6 m track: held-out poses")
ax.legend()
fig.savefig("02_track_cell.png", dpi=120)
