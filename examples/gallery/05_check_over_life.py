"""A calibration checked over a robot's life
==========================================

A calibration is true the day it is made. A collision, a motor change or a re-seated encoder can
shift a joint's zero later, and the robot keeps running with the old model. A short check campaign
(20 poses, the tracker set up anew each time) tells whether the calibration still holds: the
residual is tested against what the calibration's own uncertainty and the tracker's noise explain
(a p-value), and when it does not hold, the check names what most likely moved. An offsets-only
recalibration on the same 20 poses then restores the model without a full campaign. The robot's
life is simulated: a known change (joint 3's zero moves 0.02 deg in month 6), fixed seeds.

Every calibration and check is recorded in the robot's history (a SQLite file: what
``robocal calibrate/check --history robots.sqlite --robot-id ...`` record on the command line), and
the timeline is read back from it at the end.
"""

from dataclasses import replace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import robocal as rc
from robocal.data.simulate import sample_joints
from robocal.history.check import Uncertainty, check_calibration
from robocal.history.offsets import recalibrate_offsets, zero_shifts
from robocal.history.record import (
    calibration_record,
    calibration_uncertainty,
    check_record,
    parent_calibration,
    record_entry,
)
from robocal.history.timeline import read_timeline
from robocal.kinematics.transforms import make_transform, rotvec_to_matrix

# %% Month 0: the calibration (80 poses), recorded in the robot's history
HISTORY, ROBOT = "robots.sqlite", "IRB2600-4711"
nominal = rc.Robot.from_catalog("abb_irb2600")
sim = rc.simulate_tracker(nominal, 80, seed=21)
sim.data.save("calibration.csv")
result = rc.calibrate(nominal, sim.data, nongeometric="none", progress=False)
model, truth = result.robot, sim.truth
print(record_entry(HISTORY, calibration_record(result, ROBOT, [("calibration.csv", "cal")])))
# what the calibration left uncertain (covariance, noise): what a check is judged against
uncertainty = Uncertainty.from_dict(calibration_uncertainty(result))


def check_campaign(robot, month: int) -> rc.Measurements:
    """20 poses of ``robot`` measured with the tracker set up anew (another frame)."""
    rng = np.random.default_rng(month)
    turn = rotvec_to_matrix(np.deg2rad(rng.uniform(-5, 5, 3)))
    tracker = make_transform(turn, rng.uniform(-0.3, 0.3, 3)) @ robot.base
    q = sample_joints(robot, 20, rng)
    return rc.simulate_tracker(replace(robot, base=tracker), joints=q, as_is=True,
                               seed=month).data


# %% The robot's life: a check every three months; in month 6 a collision moves theta3
history = []
for month in (3, 6, 9, 12):
    if month == 6:
        truth = truth.with_values({"theta3": truth.get("theta3") + np.deg2rad(0.02)})
    data = check_campaign(truth, month)
    data.save(f"check_{month:02d}.csv")
    check = check_calibration(model, data, uncertainty)
    print(f"month {month:>2}: {check.summary().splitlines()[0]}")
    parent = parent_calibration(HISTORY, ROBOT, model)  # the calibration under check
    record_entry(HISTORY, check_record(check, ROBOT, model, f"check_{month:02d}.csv", parent))
    history.append((month, check.rms_mm, check.predicted_rms_mm, check.verdict))
    if check.verdict == "changed":
        moved = check.changed_parameters[0]
        print(f"          most likely moved: {moved['name']} {moved['shift']:+.4f} "
              f"+- {moved['sigma']:.4f} {moved['unit']} (true change +0.0200 deg)")
        # the joint zeros refitted on the same 20 poses; the links are kept
        fixed = recalibrate_offsets(nominal, model, data, progress=False)
        shift = {s["name"]: s["shift"] for s in zero_shifts(fixed, model)}["theta3"]
        print(f"          offsets-only recalibration: theta3 {shift:+.4f} deg")
        record_entry(HISTORY, calibration_record(fixed, ROBOT, [(f"check_{month:02d}.csv", "cal")],
                                                 parent=parent, offsets_only=True))
        model = fixed.robot
        uncertainty = Uncertainty.from_dict(calibration_uncertainty(fixed))

# %% The timeline, read back from the history (`robocal history` prints and draws the same)
timeline = read_timeline(HISTORY, ROBOT)
for entry in timeline.entries:
    what = entry["verdict"] if entry["kind"] == "check" else "offsets only" if entry.get(
        "offsets_only") else "full"
    print(f"#{entry['id']} {entry['kind']:<11} {what:<12} RMS {entry['rms']:.4f} mm")
timeline.write(report="history.html")

# %% Figure: each check's RMS against what an unchanged robot would give
fig, ax = plt.subplots(figsize=(5, 3), layout="constrained")
months, rms, expected, verdicts = zip(*history, strict=True)
ax.plot(months, expected, "k:", label="expected if unchanged")
for m, r, v in zip(months, rms, verdicts, strict=True):
    ax.scatter(m, r, s=60, color="tab:red" if v == "changed" else "tab:green", zorder=3)
    ax.annotate(v, (m, r), textcoords="offset points", xytext=(6, 4))
ax.set(xlabel="month", ylabel="check RMS, mm", xticks=months, ylim=(0, 1.3 * max(rms)),
       title="IRB 2600: a calibration checked every three months")
ax.legend(loc="upper right")
fig.savefig("05_check_over_life.png", dpi=120)
