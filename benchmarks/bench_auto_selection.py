"""Does ``nongeometric="auto"`` lose to another candidate on the held-out data? Measured on the
real sets under several splits and on simulations (a 7-axis WAM-like arm, the KR 210 payload and
thermal campaign).

For every data set and split: ``auto`` (chosen by cross-validation on the calibration part only)
and every candidate it considered, each calibrated by hand with its terms named (the held-out part
only judges). Recorded per set: auto's choice and held-out RMS, the best candidate's, their ratio,
and whether auto stays within the selection's tolerance (``robocal.calibration.model_selection.
SELECTION_TOLERANCE``: the most the rule lets the chosen model's cross-validated error exceed the
lowest one) of the best candidate held out. The held-out sets are finite samples: the held-out SE
column is the standard error of auto's held-out RMS minus the best candidate's (paired over the
held-out poses), and a loss beyond the tolerance by less than it is marked "within 1 SE" (with the
excess in SEs): the held-out data cannot tell it from the split's luck.

Sets:

- Meca500 (real, FARO): the data set README's split (490 calibration poses from the cal files,
  the 70 of the val files) and random 490 / 70 pose splits of all 560 poses.
- IRB 120 (real, FARO, 3 SMRs): the README's split (first 500 / last 500) and random 500 / 500.
- WAM-like 7-axis arm (simulated): the Barrett WAM's standard DH (a3 = 45 mm, a4 = -45 mm,
  d3 = 550 mm, d5 = 300 mm, d7 = 60 mm; Barrett's published table), joint compliance of the
  shoulder and elbow under the arm's weight (up to 2e-3 rad/m), gear errors (1 sigma 3e-4 rad per
  harmonic) and backlash (1 sigma 3e-4 rad) on every joint, tracker noise 0.05 mm and a
  non-repeatable joint error of 0.1 deg per pose (a cable-driven arm's repeatability: about 2 mm,
  Barrett's specification): 150 calibration / 150 held-out poses, three seeds.
- KR 210 R2700 with payloads 0/75/150 kg and 20-35 deg C (bench_payload_thermal's campaign):
  held out at 110 kg and 28 deg C, one seed.

Run: ``PYTHONPATH=src python benchmarks/run.py auto_selection`` (about 30 min on 2 cores).
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from robocal import Robot
from robocal.calibration.evaluation import model_errors
from robocal.calibration.model_selection import SELECTION_TOLERANCE, paired_se_mm
from robocal.calibration.pipeline import calibrate
from robocal.data.datasets import irb120, meca500
from robocal.data.importer import import_tracker
from robocal.data.simulate import simulate_tracker
from robocal.kinematics.joint_errors import JointErrorModel

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results import figure, table  # noqa: E402

DS = Path(__file__).resolve().parents[2] / "shared" / "datasets"
RANDOM_SPLITS = (1,)  # more splits: add seeds (each costs a few minutes per real set)
WAM_SEEDS = (1, 2, 3)
WAM_POSES = 150
WAM_NOISE_MM = 0.05
WAM_JOINT_NOISE_DEG = 0.1
# the shoulder's and elbow's compliance under the arm's weight (rad/m) and where the masses sit
WAM_COMPLIANCE = {(2, 4): 2e-3, (2, 7): 1.5e-3, (4, 7): 2e-3, (2, 5): 1e-3, (3, 5): 5e-4, (6, 7): 1e-3}
WAM_GEAR_BACKLASH_SIGMA = 3e-4  # rad, each gear harmonic and each joint's backlash


def wam() -> Robot:
    """The Barrett WAM (7 axes) from its standard DH table and joint limits (rad)."""
    limits = [[-2.6, 2.6], [-2.0, 2.0], [-2.8, 2.8], [-0.9, 3.1], [-4.76, 1.24], [-1.6, 1.6], [-3.0, 3.0]]
    return Robot.from_dh(theta_offsets=[0] * 7, d=[0, 0, 0.55, 0, 0.3, 0, 0.06],
                         a=[0, 0, 0.045, -0.045, 0, 0, 0],
                         alpha=[-np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, 0],
                         limits=limits, name="barrett_wam_like")


def wam_truth(robot: Robot, seed: int) -> Robot:
    """``robot`` with compliance, gear and backlash errors drawn for ``seed``."""
    rng = np.random.default_rng(seed)
    names, values = [], []
    for (i, j), c in WAM_COMPLIANCE.items():
        names.append(f"comp{i}_{j}")
        values.append(c * rng.uniform(0.7, 1.3))
    for i in range(1, 8):
        for h in ("s1", "c1", "s2", "c2"):
            names.append(f"gear{i}_{h}")
            values.append(rng.normal(0, WAM_GEAR_BACKLASH_SIGMA))
        names.append(f"backlash{i}")
        values.append(rng.normal(0, WAM_GEAR_BACKLASH_SIGMA))
    return replace(robot, joint_errors=JointErrorModel(tuple(names), np.array(values)))


def _sets():
    """(label, nominal robot, calibration, held-out) of every set and split, the README splits
    and the 7-axis case first."""
    robot = wam()
    for seed in WAM_SEEDS:
        sim = simulate_tracker(wam_truth(robot, seed), 2 * WAM_POSES, noise_mm=WAM_NOISE_MM, seed=seed,
                               joint_noise_deg=WAM_JOINT_NOISE_DEG)
        yield f"WAM-like 7-axis sim (seed {seed})", robot, *sim.data.split_poses(WAM_POSES, seed=0)
    if DS.is_dir():
        meca, irb = Robot.from_catalog("meca500"), Robot.from_catalog("abb_irb120")
        yield "Meca500, README split 490/70", meca, *meca500(DS)
        yield "IRB 120, README split 500/500", irb, *irb120(DS)
        folder = DS / "meca500-faro"
        files = sorted(folder.glob("cal_data__*_Output.csv")) + sorted(folder.glob("val_data__*_Output.csv"))
        every = import_tracker(files, joints="cols=0-5:deg", points="cols=6-8:m").data
        for s in RANDOM_SPLITS:
            yield f"Meca500, random 490/70 (seed {s})", meca, *every.split_poses(490, seed=s)
        folder = DS / "irb120-faro"
        every = import_tracker(joints=f"{folder / 'measured_joints.txt'}:cols=0-5:deg",
                               points=[f"{folder / f'measured_SMR_{k}.txt'}:mm" for k in (1, 2, 3)]).data
        for s in RANDOM_SPLITS:
            yield f"IRB 120, random 500/500 (seed {s})", irb, *every.split_poses(500, seed=s)
    robot = Robot.from_catalog("kuka_kr210_r2700")
    cal = simulate_tracker(robot, 300, noise_mm=0.02, seed=1, payloads=[0, 75, 150], temperatures=(20, 35))
    held = simulate_tracker(cal.truth, 100, noise_mm=0.02, seed=101, as_is=True, payloads=[110],
                            temperatures=(28, 28))
    yield "KR 210 payload/thermal sim (seed 1)", robot, cal.data, held.data


def _paired_se_mm(model, other, held) -> float:
    """Standard error (mm) of ``model``'s held-out RMS minus ``other``'s: the selection's own paired
    rule (`robocal.calibration.model_selection.paired_se_mm`) on the held-out poses' shares of the
    mean squared error (what the held-out sample can resolve)."""
    pose = np.unique(held.pose_id, return_inverse=True)[1]
    share = [np.bincount(pose, weights=np.sum(model_errors(m, held) ** 2, axis=1)) / held.pose_id.size
             for m in (model, other)]
    rms_mm = [np.sqrt(s.sum()) * 1e3 for s in share]
    return paired_se_mm(share[0], share[1], rms_mm[0], rms_mm[1])


def _spec(terms) -> str:
    return ",".join(terms) if terms else "none"


def main() -> None:
    rows, worst = [], 0.0
    for label, robot, cal, held in _sets():
        t0 = time.perf_counter()
        auto = calibrate(robot, cal, validation=held, nongeometric="auto")
        ms = auto.model_selection
        named = {_spec(c["terms"]): calibrate(robot, cal, validation=held, nongeometric=_spec(c["terms"]))
                 for c in ms["candidates"]}
        rms = {k: r.validation["rms"] for k, r in named.items()}
        best = min(rms, key=rms.get)
        ratio = auto.validation["rms"] / rms[best]
        worst = max(worst, ratio)
        se = _paired_se_mm(auto.robot, named[best].robot, held)
        excess = auto.validation["rms"] - (1 + SELECTION_TOLERANCE) * rms[best]
        verdict = "yes" if excess <= 0 else f"within 1 SE ({excess / se:.1f})" if excess <= se else "NO"
        rows.append([label, _spec(ms["chosen_terms"]), f"{auto.validation['rms']:.4f}", best,
                     f"{rms[best]:.4f}", f"{ratio:.3f}", f"{se:.4f}", f"{rms['none']:.4f}", verdict,
                     f"{time.perf_counter() - t0:.0f}"])
        print("  " + " | ".join(str(c) for c in rows[-1]), flush=True)
    table(f"auto against every candidate it considered, held out (RMS mm; tolerance "
          f"{SELECTION_TOLERANCE:.0%})",
          ["data", "auto chose", "auto", "best candidate", "best", "auto / best", "held-out SE",
           "geometric", "within tolerance", "time s"], rows, key="auto_vs_candidates")
    figure("auto_worst_ratio", f"{worst:.3f}")
    figure("selection_tolerance", f"{SELECTION_TOLERANCE:.0%}")


if __name__ == "__main__":
    main()
