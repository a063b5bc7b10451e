"""Held-out accuracy of geometric lsq vs + non-geometric terms vs the seed-002 network, on the
real IRB 120 and Meca500 data (skipped when ../shared/datasets is absent) and simulated IRB 2600."""

from __future__ import annotations

import time
from pathlib import Path

from robocal import Robot
from robocal.calibration import calibrate
from robocal.data.importer import import_tracker
from robocal.data.simulate import simulate_tracker

DS = Path(__file__).resolve().parents[2] / "shared" / "datasets"


def _sets():
    sim = simulate_tracker(Robot.from_catalog("abb_irb2600"), 200, noise_mm=0.02, seed=1)
    yield "abb_irb2600 (simulated)", "abb_irb2600", *sim.data.split_poses(0.5, seed=0)
    if not DS.is_dir():
        return
    m = DS / "meca500-faro"
    cal, val = (import_tracker(sorted(m.glob(f"{p}_data__*_Output.csv")), joints="cols=0-5:deg",
                               points="cols=6-8:m").data for p in ("cal", "val"))
    yield "meca500 (real)", "meca500", cal, val
    i = DS / "irb120-faro"
    d = import_tracker(joints=f"{i}/measured_joints.txt:cols=0-5:deg",
                       points=[f"{i}/measured_SMR_{s}.txt:mm" for s in (1, 2, 3)]).data
    yield "abb_irb120 (real)", "abb_irb120", d.subset(d.pose_id < 500), d.subset(d.pose_id >= 500)


RUNS = [("lsq", {}), ("lsq", {"nongeometric": "gear"}), ("lsq", {"nongeometric": "compliance"}),
        ("lsq", {"nongeometric": "compliance,gear"}), ("lsq", {"nongeometric": "backlash"}),
        ("lsq", {"nongeometric": "gear,backlash"}), ("lsq", {"nongeometric": "compliance,gear,backlash"}),
        ("neural", {}), ("neural", {"outputs": "all"})]


def main() -> None:
    print(f"{'data':24s} {'method':34s} {'cal RMS':>8s} {'held-out RMS':>12s} {'max':>7s} {'time':>6s}")
    for label, name, cal, val in _sets():
        for method, kw in RUNS:
            t = time.perf_counter()
            res = calibrate(Robot.from_catalog(name), cal, method=method, validation=val, **kw)
            desc = method + "".join(f" {k}={v}" for k, v in kw.items())
            print(f"{label:24s} {desc:34s} {res.after['rms']:8.4f} {res.validation['rms']:12.4f} "
                  f"{res.validation['max']:7.3f} {time.perf_counter() - t:6.1f}s")


if __name__ == "__main__":
    main()
