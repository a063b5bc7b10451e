"""Program filter benchmark: speed on 10,000-target programs in each format (goal < 5 s) and the
simulated-truth goal on 200-target programs (within 1.2x of a perfect filter, >= 10x better than
the unfiltered program). No open-source peer filters robot programs; the reference measured in the
same run is rc.compensate on the same poses (the IK alone, without reading and writing the file)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from timing import best_time

import robocal as rc
from robocal.compensate import controller_model
from robocal.data.simulate import perturbed
from robocal.ik.singularity import singularity_distance
from robocal.kinematics.transforms import make_transform
from robocal.programs import filter_program
from robocal.programs.simulate import truth_experiment, write_program

CASES = [("rapid", "abb_irb2600"), ("krl", "kuka_kr16_2"), ("fanuc", "fanuc_lrmate200id"),
         ("urscript", "ur5")]
# speed only: the UR program as PolyScope exports it, one pose variable per waypoint
SPEED_CASES = [(d, name, False) for d, name in CASES] + [("urscript", "ur5", True)]


def _joints(nominal, n, rng, dialect):
    lo, hi = np.maximum(nominal.limits[:, 0], -np.pi) * 0.7, np.minimum(nominal.limits[:, 1], np.pi) * 0.7
    if dialect == "urscript":  # a continuous path, as a UR program is
        steps = rng.uniform(-1, 1, (3 * n, 6)) * np.deg2rad(1.5)
        q = np.clip(np.deg2rad([0, -90, 90, -90, -90, 0]) + np.cumsum(steps, axis=0), lo, hi)
    else:
        q = rng.uniform(lo, hi, (3 * n, 6))
    return q[singularity_distance(nominal, q).sigma_rel > 0.02][:n]


def speed(n: int = 10_000) -> None:
    tool = make_transform(np.eye(3), np.array([0.03, 0.0, 0.12]))
    frame = make_transform(np.eye(3), np.array([0.4, -0.1, 0.05]))
    for dialect, name, variables in SPEED_CASES:
        nominal = rc.Robot.from_catalog(name)
        cal = perturbed(nominal, 0)
        q = _joints(nominal, n, np.random.default_rng(1), dialect)
        with tempfile.TemporaryDirectory() as tmp:
            paths, tools, frames = write_program(dialect, tmp, nominal, q, tool, frame,
                                                 variables=variables)
            size = sum(Path(p).stat().st_size for p in paths)
            t, res = best_time(lambda p=paths, tl=tools, fr=frames, c=cal, nm=nominal:
                               filter_program(p, c, nm, tools=tl, frames=fr, keep_unreached=True), repeat=3)
        targets = controller_model(nominal, nominal, tool=tool).fk(q)
        seeds = q if dialect == "urscript" else None
        t_comp, _ = best_time(lambda tg=targets, s=seeds, c=cal, nm=nominal:
                              rc.compensate(c, nm, tg, seeds=s, targets_frame="robot", tool=tool), repeat=3)
        filtered = sum(r["filtered"] for r in res.rows)
        label = dialect + (" (a variable per waypoint)" if variables else "")
        print(f"{label:9s} {name:18s} {len(q)} targets ({size / 1e6:.1f} MB): filter {t:.2f} s "
              f"({t / len(q) * 1e6:.0f} us/target, goal < 5 s: {'met' if t < 5 else 'NOT met'}), {filtered} "
              f"filtered; rc.compensate alone {t_comp:.2f} s (filter / compensate {t / t_comp:.1f}x)")


def truth(seeds=(0, 1, 2)) -> None:
    print("simulated truth, 200 targets, work object + real tool (TCP by the 4-point method on the "
          "calibrated model); RMS (max) error from the intended targets")
    for dialect, name in CASES:
        rows = [truth_experiment(dialect, name, 200, seed) for seed in seeds]
        ratio = [r["filtered"]["rms_mm"] / r["perfect"]["rms_mm"] for r in rows]
        gain = [r["unfiltered"]["rms_mm"] / r["filtered"]["rms_mm"] for r in rows]
        for key in ("filtered", "perfect", "unfiltered"):
            mm = ", ".join(f"{r[key]['rms_mm']:.4f} ({r[key]['max_mm']:.3f})" for r in rows)
            deg = ", ".join(f"{r[key]['rms_deg']:.4f}" for r in rows)
            print(f"  {dialect:9s} {key:10s} mm: {mm}; deg RMS: {deg}")
        print(f"  {dialect:9s} filtered / perfect {min(ratio):.3f}-{max(ratio):.3f} (goal <= 1.2), "
              f"unfiltered / filtered {min(gain):.1f}-{max(gain):.1f}x (goal >= 10)")


def main() -> None:
    speed()
    truth()


if __name__ == "__main__":
    main()
