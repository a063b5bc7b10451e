"""Issue 20: well-posed estimates on the arms robocal was not developed on (docs/priors.md).

Simulations of the held-back campaigns (tests/simulated_campaigns.py): the UR5 with the SMR on
the flange axis (1000 grid poses, gear and cyclic errors) with the default command (auto) and the
geometric model, 20 of its poses planned by ``plan_poses`` (= ``robocal poses --from``), the
7-axis arm through the API with defaults; robust on six planned 25-pose KUKA KR 16-2 campaigns;
genetic and swarm with their defaults on a 100-pose IRB 2600 campaign. Prints convergence,
iterations, held-out errors, the largest link sigma / correction and the time (the default
calibration of 1000 tracker poses, auto included: best of 3).

``python benchmarks/bench_priors.py``
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from timing import best_time

import robocal as rc
from robocal.campaign.planner import plan_poses
from robocal.data.simulate import simulate_tracker

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from simulated_campaigns import seven_axis_campaign, ur5_campaign  # noqa: E402


def _worst_link(result) -> str:
    """The largest sigma and correction of the estimated link parameters (mm, deg)."""
    rows = [p for p in result.parameter_table() if p["status"] == "estimated" and "." not in p["name"]
            and p["name"].rstrip("0123456789") in ("a", "d", "alpha", "beta", "theta")]
    out = []
    for unit in ("mm", "deg"):
        mine = [p for p in rows if p["unit"] == unit]
        out.append(f"{unit}: sigma <= {max(p['sigma'] for p in mine):.3g}, |correction| <= "
                   f"{max(abs(p['correction']) for p in mine):.3g}")
    return "; ".join(out)


def _row(label: str, result, seconds: float) -> None:
    v, vb = result.validation, result.validation_before
    print(f"  {label:<34} {result.solver.status.value:<10} {result.solver.nit:>3} it  held-out mean "
          f"{vb['mean']:.4f} -> {v['mean']:.4f} mm, RMS {v['rms']:.4f}  {seconds:6.2f} s")
    print(f"  {'':<34} {_worst_link(result)}; held: {', '.join(result.identifiability.undetermined) or '-'}")


def main() -> None:
    nominal, cal, val, sim = ur5_campaign()
    print(f"UR5, SMR 34 mm on the flange axis, 1000 grid poses + 200 held out, noise floor "
          f"{sim.noise_floor_mm:.4f} mm (3-D RMS)")
    for label, ng in (("default (auto)", "default"), ("geometric", None)):
        seconds, result = best_time(lambda ng=ng: rc.calibrate(nominal, cal, validation=val, nongeometric=ng))
        _row(label, result, seconds)
        if result.model_selection:
            t = result.model_selection["time_s"]
            print(f"  {'':<34} auto: superset {t['superset_fit']:.2f} s, selection {t['selection']:.2f} s, "
                  f"final {t['final_fit']:.2f} s; chosen {', '.join(result.model_selection['chosen_terms'])}")
    plan = plan_poses(nominal, 20, candidates=cal, smr=[[0, 0, 0.034]], seed=0)
    chosen = cal.subset(np.isin(cal.pose_id, np.unique(cal.pose_id)[plan.candidate_index]))
    t0 = time.perf_counter()
    _row("20 planned poses", rc.calibrate(nominal, chosen, validation=val), time.perf_counter() - t0)

    robot, cal7, val7 = seven_axis_campaign()
    print("7-axis arm (WAM-like standard DH via the API), 216 poses + 100 held out, 0.3 deg unmodelled")
    t0 = time.perf_counter()
    _row("defaults", rc.calibrate(robot, cal7, validation=val7), time.perf_counter() - t0)

    print("robust, planned 25-pose KUKA KR 16-2 campaigns (plan_poses then simulate --joints)")
    kr = rc.Robot.from_catalog("kuka_kr16_2")
    for seed in range(6):
        plan = plan_poses(kr, 25, seed=seed)
        s = simulate_tracker(kr, joints=plan.joints, seed=seed)
        res = rc.calibrate(kr, s.data, method="robust")
        print(f"  seed {seed}: {res.solver.message}; RMS {res.after['rms']:.4f} mm (floor "
              f"{s.noise_floor_mm:.4f})")

    print("genetic and swarm with their defaults, IRB 2600, 100 poses")
    irb = rc.Robot.from_catalog("abb_irb2600")
    s = simulate_tracker(irb, 100, seed=0)
    for method in ("lsq", "genetic", "swarm"):
        t0 = time.perf_counter()
        res = rc.calibrate(irb, s.data, method=method)
        print(f"  {method:<8} success {res.solver.success}: {res.solver.message}; RMS "
              f"{res.after['rms']:.5f} mm  {time.perf_counter() - t0:.2f} s")


if __name__ == "__main__":
    main()
