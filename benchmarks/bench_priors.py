"""Issue 20: well-posed estimates on the arms robocal was not developed on (docs/priors.md).

Simulations of the held-back campaigns (tests/simulated_campaigns.py): the UR5 with the SMR on
the flange axis (1000 grid poses, gear and cyclic errors) with the default command (auto) and the
geometric model, 20 of its poses planned by ``plan_poses`` (= ``robocal poses --from``), the
7-axis arm through the API with defaults; robust on six planned 25-pose KUKA KR 16-2 campaigns;
genetic and swarm with their defaults on a 100-pose IRB 2600 campaign. Prints convergence,
iterations, held-out errors, the largest link sigma / correction and the time (the default
calibration of 1000 tracker poses, auto included: best of 3) as tables for docs/priors.md.

``python benchmarks/bench_priors.py``
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from results import figure, table
from timing import best_time

import robocal as rc
from robocal.campaign.planner import plan_poses
from robocal.data.simulate import simulate_tracker

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from simulated_campaigns import seven_axis_campaign, ur5_campaign  # noqa: E402


def _worst_link(result) -> tuple[str, str]:
    """The largest sigma and |correction| of the estimated link parameters: (mm, deg) texts."""
    rows = [p for p in result.parameter_table() if p["status"] == "estimated" and "." not in p["name"]
            and p["name"].rstrip("0123456789") in ("a", "d", "alpha", "beta", "theta")]
    out = []
    for unit in ("mm", "deg"):
        mine = [p for p in rows if p["unit"] == unit]
        out.append(f"{max(p['sigma'] for p in mine):.3g} / {max(abs(p['correction']) for p in mine):.3g}")
    return out[0], out[1]


COLUMNS = ["case", "status", "iterations", "held-out mean before -> after (mm)", "held-out RMS (mm)",
           "time (s)", "largest link sigma / correction, mm", "same, deg", "held at nominal"]


def _row(key: str, label: str, result, seconds: float) -> list:
    """One table row; records the figures the documentation quotes under ``key``_..."""
    v, vb = result.validation, result.validation_before
    mm, deg = _worst_link(result)
    held = ", ".join(result.identifiability.undetermined) or "-"
    figure(f"{key}_status", result.solver.status.value)
    figure(f"{key}_nit", str(result.solver.nit))
    figure(f"{key}_mean_before_mm", f"{vb['mean']:.2f}")
    figure(f"{key}_mean_mm", f"{v['mean']:.2f}")
    figure(f"{key}_rms_mm", f"{v['rms']:.4f}")
    figure(f"{key}_seconds", f"{seconds:.2f}")
    figure(f"{key}_held", held)
    return [label, result.solver.status.value, result.solver.nit, f"{vb['mean']:.4f} -> {v['mean']:.4f}",
            f"{v['rms']:.4f}", f"{seconds:.2f}", mm, deg, held]


def main() -> None:
    nominal, cal, val, sim = ur5_campaign()
    floor = figure("ur5_floor_mm", f"{sim.noise_floor_mm:.4f}")
    rows = []
    for key, label, ng in (("ur5_default", "default (auto), best of 3", "default"),
                           ("ur5_geometric", "geometric, best of 3", None)):
        seconds, result = best_time(lambda ng=ng: rc.calibrate(nominal, cal, validation=val, nongeometric=ng))
        rows.append(_row(key, label, result, seconds))
        if result.model_selection:
            t = result.model_selection["time_s"]
            print(f"  auto: superset {t['superset_fit']:.2f} s, selection {t['selection']:.2f} s, "
                  f"final {t['final_fit']:.2f} s; chosen {', '.join(result.model_selection['chosen_terms'])}")
    plan = plan_poses(nominal, 20, candidates=cal, smr=[[0, 0, 0.034]], seed=0)
    chosen = cal.subset(np.isin(cal.pose_id, np.unique(cal.pose_id)[plan.candidate_index]))
    t0 = time.perf_counter()
    result = rc.calibrate(nominal, chosen, validation=val)
    rows.append(_row("ur5_planned20", "20 planned poses (default)", result, time.perf_counter() - t0))
    table(f"UR5, SMR 34 mm on the flange axis, gear and cyclic errors, 1000 grid poses + 200 held out, "
          f"noise floor {floor} mm (3-D RMS)", COLUMNS, rows, key="ur5")

    robot, cal7, val7 = seven_axis_campaign()
    t0 = time.perf_counter()
    result = rc.calibrate(robot, cal7, validation=val7)
    table("7-axis arm (WAM-like standard DH via the API), 216 poses + 100 held out, 0.3 deg unmodelled "
          "joint coupling, defaults", COLUMNS,
          [_row("seven_axis", "defaults", result, time.perf_counter() - t0)], key="seven_axis")

    kr = rc.Robot.from_catalog("kuka_kr16_2")
    rows, converged = [], 0
    for seed in range(6):
        plan = plan_poses(kr, 25, seed=seed)
        s = simulate_tracker(kr, joints=plan.joints, seed=seed)
        res = rc.calibrate(kr, s.data, method="robust")
        converged += bool(res.solver.success)
        rows.append([seed, res.solver.message, f"{res.after['rms']:.4f}", f"{s.noise_floor_mm:.4f}"])
    figure("robust_converged", f"{converged} of 6")
    table("robust, planned 25-pose KUKA KR 16-2 campaigns (plan_poses, then simulated at those joints)",
          ["seed", "solver", "RMS (mm)", "noise floor (mm)"], rows, key="robust")

    irb = rc.Robot.from_catalog("abb_irb2600")
    s = simulate_tracker(irb, 100, seed=0)
    rows = []
    for method in ("lsq", "genetic", "swarm"):
        t0 = time.perf_counter()
        res = rc.calibrate(irb, s.data, method=method)
        rows.append([method, res.solver.success, res.solver.message, f"{res.after['rms']:.5f}",
                     f"{time.perf_counter() - t0:.2f}"])
    table("genetic and swarm with their defaults, abb_irb2600, 100 simulated poses",
          ["method", "converged", "solver", "RMS (mm)", "time (s)"], rows, key="metaheuristics")


if __name__ == "__main__":
    main()
