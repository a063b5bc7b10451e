"""Held-out accuracy of the payload and thermal terms on a simulated KR 210 R2700 cell.

Campaign: 300 poses (tracker points, 0.02 mm isotropic noise) in three blocks at 0, 75 and
150 kg (centre of mass 250 mm along the flange's z axis), the arm warming from 20 to 35 deg C
within each block (:mod:`robocal.data.simulate_conditions`). Held out: 100 other poses of the same
true robot at 110 kg and 28 deg C (``as_is``). Calibrated with the geometric model,
``nongeometric="payload,thermal"`` and ``"auto"``; the held-out RMS is compared with the noise
floor of the held-out set (goals: 1.3x for the named terms, 1.5x for auto). Three seeds.

Run: ``PYTHONPATH=src python benchmarks/bench_payload_thermal.py``.
"""

from __future__ import annotations

import time

from robocal import Robot
from robocal.calibration import calibrate
from robocal.data.simulate import simulate_tracker

SEEDS = (1, 2, 3)
N_CAL, N_HELD = 300, 100
NOISE_MM = 0.02
GOALS = {"payload,thermal": 1.3, "auto": 1.5}


def campaign(seed: int):
    """(calibration data, held-out data, held-out noise floor mm, truth)."""
    robot = Robot.from_catalog("kuka_kr210_r2700")
    cal = simulate_tracker(robot, N_CAL, noise_mm=NOISE_MM, seed=seed, payloads=[0, 75, 150],
                           temperatures=(20, 35))
    held = simulate_tracker(cal.truth, N_HELD, noise_mm=NOISE_MM, seed=seed + 100, as_is=True,
                            payloads=[110], temperatures=(28, 28))
    return cal.data, held.data, held.noise_floor_mm, cal.truth


def main() -> None:
    robot = Robot.from_catalog("kuka_kr210_r2700")
    print(f"{'seed':>4} {'model':>16} {'held-out RMS mm':>16} {'floor mm':>9} {'ratio':>6} {'goal':>5} "
          f"{'time s':>7}  chosen / thermal k (truth 11.5e-6)")
    worst = {}
    for seed in SEEDS:
        data, held, floor, _ = campaign(seed)
        for model in ("none", "payload,thermal", "auto"):
            t0 = time.perf_counter()
            res = calibrate(robot, data, validation=held, nongeometric=model)
            dt = time.perf_counter() - t0
            rms = res.validation["rms"]
            ratio = rms / floor
            worst[model] = max(worst.get(model, 0.0), ratio)
            errors = res.robot.joint_errors
            k = errors.thermal_k() if errors is not None else None
            chosen = res.model_selection["chosen_terms"] if getattr(res, "model_selection", None) else ""
            goal = GOALS.get(model)
            print(f"{seed:>4} {model:>16} {rms:>16.4f} {floor:>9.4f} {ratio:>6.2f} "
                  f"{'' if goal is None else f'{goal:.1f}':>5} {dt:>7.1f}  {chosen} "
                  f"{'' if k is None else f'k={k:.4g}'}")
    for model, goal in GOALS.items():
        verdict = "meets" if worst[model] <= goal else "MISSES"
        print(f"worst ratio {model}: {worst[model]:.2f} ({verdict} the {goal}x goal)")
    print(f"worst ratio geometric only: {worst['none']:.2f}")


if __name__ == "__main__":
    main()
