"""A UR's factory calibration, refined, into ROS
===============================================

Every Universal Robots arm leaves the factory with its own calibration (``calibration.conf`` on
the controller: DH deltas per joint). robocal reads it exactly as a model, a laser-tracker
campaign refines it (here: simulated from an arm that differs from its factory calibration by a
few tenths of a millimetre, fixed seed), and the refined kinematics go into the vendor's own URDF
(``ur_description``, expanded by xacro): only the joint origins change, so meshes, limits and
MoveIt configurations keep working. The written file's forward kinematics are checked against
the calibrated model.
"""

from importlib.resources import files
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import robocal as rc
from robocal.kinematics.manufacturer.ur import import_calibration

demo = files("robocal") / "demo_data"  # small sample files shipped with the package
conf = Path("calibration.conf")  # as copied from the controller
conf.write_text((demo / "calibration.conf").read_text())
vendor_urdf = Path("ur5e.urdf")  # `xacro ur.urdf.xacro ur_type:=ur5e name:=ur` expanded
vendor_urdf.write_text((demo / "ur5e.urdf").read_text())

# %% The factory calibration, read exactly into a robocal model
imported = import_calibration(conf, "ur5e")
print(imported.summary())
factory = imported.robot
catalog = rc.Robot.from_catalog("ur5e")
q = np.random.default_rng(0).uniform(-np.pi, np.pi, (200, 6))
moved = np.linalg.norm(factory.fk(q)[:, :3, 3] - catalog.fk(q)[:, :3, 3], axis=1) * 1e3
print(f"the factory calibration moves the flange up to {moved.max():.2f} mm from nominal")

# %% A tracker campaign on the real arm (simulated: the factory model + small errors)
sim = rc.simulate_tracker(factory, 80, noise_mm=0.02, error_scale=0.3, seed=11)
calibration, validation = sim.data.split_poses(50)
result = rc.calibrate(factory, calibration, validation=validation, nongeometric="none",
                      progress=False)  # the factory model is the start: only what it misses
print(f"validation RMS: factory model {result.validation_before['rms']:.3f} mm, refined "
      f"{result.validation['rms']:.4f} mm (noise floor {sim.noise_floor_mm:.4f} mm)")
gap = np.linalg.norm(result.robot.fk(q)[:, :3, 3] - sim.truth.fk(q)[:, :3, 3], axis=1) * 1e3
print(f"refined model vs the true arm over the whole joint space: "
      f"RMS {np.sqrt(np.mean(gap**2)):.4f} mm")

# %% Into the vendor's URDF: the refined model drawn in ur_description's own frames
out = rc.export_urdf_like(result.robot, vendor_urdf, nominal=factory, vendor_model="ur5e",
                          output="ur5e_calibrated.urdf")
out.write()
print(out.summary())

# %% Figure: how far each joint's origin moved from the vendor's nominal description
fig, ax = plt.subplots(figsize=(5, 3), layout="constrained")
names = [s.joint.replace("_joint", "") for s in out.shifts]
ax.bar(names, [s.origin_mm for s in out.shifts])
ax.set(ylabel="joint origin shift, mm",
       title="UR5e: calibrated joint origins vs ur_description's")
ax.tick_params(axis="x", labelrotation=30)
fig.savefig("04_ur_factory_to_ros.png", dpi=120)
