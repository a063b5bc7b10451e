"""Keeping a calibration true: the check's verdicts on simulated IRB 2600 check campaigns.

A calibration from 100 simulated tracker poses (0.02 mm noise, the command's defaults), then check
campaigns of 20 random poses with the tracker moved 0.1-0.5 m and turned 2-10 deg since: 20 of the
unchanged robot (goal: ``holds`` in >= 18) and 20 after a 0.01 deg change of the joint-2 zero
(goal: ``changed`` in >= 18, theta2 named first in >= 16 with the shift within 3 sigma). The
false-alarm rate over 5 calibrations x 40 unchanged campaigns, with the noise estimated by the
calibration (F-test) and stated (chi-square). The time of one check. Offsets-only recalibration on
five such 20-pose campaigns of the changed robot, judged on 40 held-out poses of it (goal: held-out
RMS <= 1.3x the original calibration's). Four ``robocal calibrate --history`` processes started
together on one SQLite file (goal: all recorded). A check campaign planned for the joint zeros
(``robocal poses --check``: 20 of 200 candidate poses) against 20 random poses of the same
candidates, on changes smaller than the goals' (how often each says ``changed``).

``python benchmarks/bench_check.py``
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from results import figure, table

import robocal as rc
from robocal.campaign.planner import plan_poses
from robocal.data.simulate import sample_joints, simulate_tracker
from robocal.history.check import Uncertainty, check_calibration
from robocal.history.offsets import offsets_params, recalibrate_offsets
from robocal.history.record import calibration_uncertainty
from robocal.history.store import History
from robocal.kinematics.transforms import make_transform, rotvec_to_matrix

NOMINAL = "abb_irb2600"
CAL_POSES, VAL_POSES, CHECK_POSES, CAMPAIGNS = 100, 40, 20, 20
SHIFT_DEG = 0.01


def calibration(seed: int):
    """(truth, result): a default calibration on CAL_POSES poses, VAL_POSES held out."""
    nominal = rc.Robot.from_catalog(NOMINAL)
    sim = simulate_tracker(nominal, CAL_POSES + VAL_POSES, seed=seed)
    cal = sim.data.first_poses(CAL_POSES)
    val = sim.data.subset(~np.isin(sim.data.pose_id, cal.pose_id))
    return sim.truth, rc.calibrate(nominal, cal, validation=val, progress=False)


def tracker_moved(robot, rng: np.random.Generator):
    """``robot`` seen from a tracker moved 0.1-0.5 m and turned 2-10 deg about a random axis."""
    axis, step = rng.normal(size=3), rng.normal(size=3)
    turn = rotvec_to_matrix(axis / np.linalg.norm(axis) * np.deg2rad(rng.uniform(2, 10)))
    move = make_transform(turn, step / np.linalg.norm(step) * rng.uniform(0.1, 0.5))
    return replace(robot, base=move @ robot.base)


def campaign(robot, rng: np.random.Generator, n: int = CHECK_POSES):
    """Point measurements of ``robot`` at ``n`` random poses, the tracker moved."""
    q = sample_joints(robot, n, rng)
    return simulate_tracker(tracker_moved(robot, rng), joints=q, as_is=True,
                            seed=int(rng.integers(2**31))).data


def main() -> None:
    truth, result = calibration(seed=11)
    unc = Uncertainty.from_dict(calibration_uncertainty(result))
    print(f"calibration: held-out RMS {result.validation['rms']:.4f} mm, noise estimate "
          f"{unc.noise_m * 1e3:.4f} mm ({unc.dof} dof), {len(unc.names)} parameters in the covariance")
    rng = np.random.default_rng(2026)
    changed = truth.with_values({"theta2": truth.get("theta2") + np.deg2rad(SHIFT_DEG)})
    t0 = time.perf_counter()
    same = [check_calibration(result.robot, campaign(truth, rng), unc, fit_frame=True)
            for _ in range(CAMPAIGNS)]
    seconds = (time.perf_counter() - t0) / CAMPAIGNS
    moved = [check_calibration(result.robot, campaign(changed, rng), unc, fit_frame=True)
             for _ in range(CAMPAIGNS)]
    holds = sum(r.verdict == "holds" for r in same)
    flagged = sum(r.verdict == "changed" for r in moved)
    first = [r.changed_parameters[0] for r in moved if r.changed_parameters]
    named = sum(c["name"] == "theta2" for c in first)
    within = sum(c["name"] == "theta2" and abs(c["shift"] - SHIFT_DEG) <= 3 * c["sigma"] for c in first)
    shifts = [c["shift"] for c in first if c["name"] == "theta2"]
    table("IRB 2600, 20-pose check campaigns, tracker moved", ["campaigns", "result", "goal"], [
        [f"{CAMPAIGNS} unchanged", f"holds in {figure('holds', f'{holds} of {CAMPAIGNS}')}", ">= 18"],
        [f"{CAMPAIGNS} theta2 + {SHIFT_DEG} deg",
         f"changed in {figure('changed', f'{flagged} of {CAMPAIGNS}')}", ">= 18"],
        ["", f"theta2 named first in {figure('named', f'{named} of {CAMPAIGNS}')}", ">= 16"],
        ["", f"... with the shift within 3 sigma in {figure('within', f'{within} of {CAMPAIGNS}')}", ">= 16"],
    ], key="goals")
    print(f"theta2 shifts found: mean {np.mean(shifts):.5f} deg, sd {np.std(shifts):.5f} deg; "
          f"sigma {np.mean([c['sigma'] for c in first]):.5f} deg")
    figure("check_seconds", f"{seconds:.2f}")
    print(f"one check of {CHECK_POSES} poses: {seconds:.2f} s")
    offsets_only(truth, changed, result, rng)
    planned_vs_random(truth, result, unc, rng)
    false_alarms(rng)
    concurrent_writers(result)


def concurrent_writers(result, n: int = 4) -> None:
    """``n`` calibrate processes started at once, all recording in one history file."""
    with tempfile.TemporaryDirectory() as tmp:
        data, history = Path(tmp) / "cal.csv", Path(tmp) / "history.sqlite"
        result.problem.datasets[0].save(data)
        command = [sys.executable, "-c", "import sys; from robocal.cli import main; sys.exit(main())",
                   "--quiet", "calibrate", str(data), "--robot", NOMINAL, "--nongeometric", "none",
                   "--history", str(history), "--robot-id", "shared"]
        procs = [subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                 for _ in range(n)]
        codes = [p.wait() for p in procs]
        errors = [p.stderr.read().strip() for p in procs if p.returncode]
        with History(history) as h:
            recorded = len(h.entries("shared"))
    print(f"{n} calibrate processes started together: exit codes {codes}, "
          f"{figure('concurrent', f'{recorded} of {n}')} recorded"
          + (f"; errors: {errors}" if errors else ""))


def offsets_only(truth, changed, result, rng: np.random.Generator) -> None:
    """Offsets-only recalibrations of ``result`` on 20-pose campaigns of ``changed``."""
    nominal, original = rc.Robot.from_catalog(NOMINAL), result.validation["rms"]
    rows, ratios = [], []
    for k in range(5):
        data = campaign(changed, rng, CHECK_POSES + VAL_POSES)
        short = data.first_poses(CHECK_POSES)
        held_out = data.subset(~np.isin(data.pose_id, short.pose_id))
        out = recalibrate_offsets(nominal, result.robot, short, validation=held_out, progress=False)
        shift = np.rad2deg(out.robot.get("theta2") - result.robot.get("theta2"))
        ratios.append(out.validation["rms"] / original)
        rows.append([k + 1, f"{out.validation_before['rms']:.4f}", f"{out.validation['rms']:.4f}",
                     f"{ratios[-1]:.2f}", f"{shift:+.4f}"])
    table(f"Offsets only after theta2 + {SHIFT_DEG} deg: {CHECK_POSES} poses, judged on {VAL_POSES} "
          f"held out (original calibration's held-out RMS {original:.4f} mm)",
          ["campaign", "held-out RMS, earlier model (mm)", "after offsets only (mm)", "ratio to original",
           "theta2 shift found (deg)"], rows, key="offsets")
    figure("offsets_ratio", f"{max(ratios):.2f}")
    figure("original_rms", f"{original:.4f}")


def planned_vs_random(truth, result, unc: Uncertainty, rng: np.random.Generator) -> None:
    """Detection of small zero changes by a planned check campaign and by random poses."""
    nominal = rc.Robot.from_catalog(NOMINAL)
    pool = sample_joints(truth, 200, rng)
    planned = plan_poses(nominal, CHECK_POSES, candidates=pool, params=offsets_params(nominal),
                         smr=truth.tool[:3, 3][None], seed=0).joints  # the SMR as the user knows it
    rows = []
    for name, shift in (("theta2", 0.002), ("theta3", 0.002), ("theta5", 0.03)):
        changed = truth.with_values({name: truth.get(name) + np.deg2rad(shift)})
        row = [f"{name} + {shift} deg"]
        for label in ("planned", "random"):
            hits = 0
            for _ in range(CAMPAIGNS):
                q = planned if label == "planned" else pool[rng.choice(len(pool), CHECK_POSES, replace=False)]
                data = simulate_tracker(tracker_moved(changed, rng), joints=q, as_is=True,
                                        seed=int(rng.integers(2**31))).data
                hits += check_calibration(result.robot, data, unc).verdict == "changed"
            row.append(f"{hits} of {CAMPAIGNS}")
        rows.append(row)
    table("Changed found by 20 poses planned for the joint zeros (poses --check) and by 20 random poses",
          ["change", "planned", "random"], rows, key="planned")


def false_alarms(rng: np.random.Generator) -> None:
    """Verdicts on unchanged robots: 5 calibrations x 40 campaigns."""
    rows, alarms = [], {"calibration": 0, "stated": 0}
    total = 0
    for seed in range(5):
        truth, result = calibration(seed=100 + seed)
        unc = Uncertainty.from_dict(calibration_uncertainty(result))
        local = {"calibration": 0, "stated": 0}
        for _ in range(40):
            data = campaign(truth, rng)
            local["calibration"] += check_calibration(result.robot, data, unc).verdict == "changed"
            local["stated"] += check_calibration(result.robot, data, unc, noise_mm=0.02).verdict == "changed"
        total += 40
        rows.append([100 + seed, f"{local['calibration']} of 40", f"{local['stated']} of 40"])
        for k in alarms:
            alarms[k] += local[k]
    rows.append(["all", figure("false_alarms", f"{alarms['calibration']} of {total}"),
                 figure("false_alarms_stated", f"{alarms['stated']} of {total}")])
    table("False alarms (changed on an unchanged robot; the test's level is 1 %)",
          ["calibration seed", "noise from the calibration (F-test)", "noise stated 0.02 mm (chi-square)"],
          rows, key="false_alarms")


if __name__ == "__main__":
    main()
