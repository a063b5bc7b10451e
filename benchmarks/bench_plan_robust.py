"""Planned campaigns on arms the planner knows only by name: ``robocal poses`` with its defaults
against random poses, on simulated arms whose SMR offset, tracker place and errors it does not know.

For each catalog arm (none of them used to choose the planner's settings) and each robot seed, the
truth is what ``robocal simulate`` draws for that seed: the arm's random errors, its SMR at a random
place on the flange (``|xy| <= 50`` mm, 50-120 mm out: off the flange axis by tens of mm) and the
tracker 2-4 m away at a random place; noise 0.02 mm per axis. The planner runs as ``robocal poses
--robot ARM -n 12`` does (5,000 generated candidates, the model's TCP as the nominal SMR, seed 0:
a user runs one), once per arm; the truth measures the 12 planned poses, and ``RANDOM_DRAWS`` sets
of 20 random poses in the joint limits; the default calibration (``rc.calibrate``) of each is
judged by its true model error (3-D RMS of the calibrated TCP against the truth's, noise free, over
1,000 random poses) and by ``HELD_OUT`` held-out measurements (3-D RMS, their noise included).
Planned 12 / random 20 is the ratio of the medians over the seeds.

Two plans per arm: the defaults (the SMR not given: the criterion averaged over its prior box,
:mod:`robocal.campaign.hypotheses`), and the same nominal SMR given as ``smr`` (the criterion at the
nominal point alone: the planner before). The planner's predicted model error and predicted
held-out RMS are compared with what the calibrations reach.
"""

from __future__ import annotations

import time

import numpy as np
import results
from common import model_error_mm

import robocal as rc
from robocal.data.simulate import simulate_tracker

ARMS = ("abb_irb2400", "abb_irb6700", "fanuc_m710ic50", "kuka_kr120_r2500", "yaskawa_gp88", "ur3e", "ur16e",
        "ur20", "kuka_kr210_r2700", "fanuc_r2000ic_165f")
SEEDS = 16
RANDOM_DRAWS = 4
HELD_OUT = 100
EVAL_POSES = 1000
PLANNED, RANDOM = 12, 20


def judged(robot, joints: np.ndarray, seed: int, q_eval: np.ndarray,
           q_val: np.ndarray) -> tuple[float, float]:
    """(true model error, held-out RMS) in mm of the default calibration of ``joints`` measured on
    the truth of ``seed``."""
    sim = simulate_tracker(robot, joints=joints, seed=seed)
    val = simulate_tracker(robot, joints=q_val, seed=seed).data  # the same truth, tracker and SMR
    result = rc.calibrate(robot, sim.data, validation=val)
    return model_error_mm(result.robot, sim.truth, q_eval), result.validation["rms"]


def main() -> None:
    rows, ratios = [], {"defaults": [], "nominal SMR": []}
    honest = []
    for name in ARMS:
        robot = rc.Robot.from_catalog(name)
        lo, hi = robot.limits.T
        q_eval = np.random.default_rng(999).uniform(lo, hi, (EVAL_POSES, robot.n_joints))
        q_val = np.random.default_rng(998).uniform(lo, hi, (HELD_OUT, robot.n_joints))
        t = time.perf_counter()
        plans = {"defaults": rc.plan_poses(robot, PLANNED)}
        seconds = time.perf_counter() - t
        plans["nominal SMR"] = rc.plan_poses(robot, PLANNED, smr=[[0.0, 0.0, 0.0]])
        random = [judged(robot, np.random.default_rng([s, k, 5]).uniform(lo, hi, (RANDOM, robot.n_joints)), s,
                         q_eval, q_val) for s in range(SEEDS) for k in range(RANDOM_DRAWS)]
        random_true = np.median([r[0] for r in random])
        cells = []
        for label, plan in plans.items():
            got = [judged(robot, plan.joints, s, q_eval, q_val) for s in range(SEEDS)]
            true, held = np.median([g[0] for g in got]), np.median([g[1] for g in got])
            ratios[label].append(true / random_true)
            cells += [f"{true:.4f}", f"{true / random_true:.3f}"]
            if label == "defaults":
                honest.append((plan.predicted_rms_mm, true, plan.predicted_heldout_mm, held))
                cells += [f"{plan.predicted_rms_mm:.4f}", f"{plan.predicted_heldout_mm:.4f}", f"{held:.4f}"]
        rows.append([name, f"{random_true:.4f}", *cells, f"{seconds:.1f}"])
    mean = {label: float(np.mean(v)) for label, v in ratios.items()}
    rows.append(["mean", "", "", f"{mean['defaults']:.3f}", "", "", "", "", f"{mean['nominal SMR']:.3f}", ""])
    results.figure("planned12_random20_defaults", f"{mean['defaults']:.3f}")
    results.figure("planned12_random20_defaults_max", f"{max(ratios['defaults']):.3f}")
    results.figure("planned12_random20_nominal_smr", f"{mean['nominal SMR']:.3f}")
    pred, true, pred_held, held = np.array(honest).T
    results.figure("predicted_over_true_model_error", f"{np.mean(pred / true):.3f}")
    results.figure("predicted_over_heldout_rms", f"{np.mean(pred_held / held):.3f}")
    results.table(f"{PLANNED} poses planned with the defaults of `robocal poses` against {RANDOM} "
                  f"random ones ({RANDOM_DRAWS} draws per robot), on simulated arms whose SMR (off the "
                  f"flange axis), tracker place and errors the planner does not know; the default "
                  f"calibration; medians over {SEEDS} robots: true model error (mm, {EVAL_POSES} random "
                  f"poses), its ratio to random {RANDOM}, the planner's predictions and the RMS of "
                  f"{HELD_OUT} held-out measurements (mm); 'nominal SMR': the same nominal SMR given (the "
                  "criterion at that point alone, as before)",
                  ["arm", f"random {RANDOM}", f"planned {PLANNED}", "ratio", "predicted",
                   "predicted held-out", "held-out", f"nominal SMR, planned {PLANNED}", "ratio", "plan s"],
                  rows, key="hidden_arms")


if __name__ == "__main__":
    main()
