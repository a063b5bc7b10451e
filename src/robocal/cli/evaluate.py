"""``robocal evaluate``: position error statistics of a model against measurements."""

from __future__ import annotations

import argparse

EPILOG = """Examples:
  robocal evaluate calibrated.yaml validation.csv --json val.json
  robocal evaluate meca500.yaml meca_val.csv --fit-frame      # nominal model: fit base and SMRs first
"""


def add_parser(sub) -> None:
    p = sub.add_parser("evaluate", help="position error statistics of a model on measurements",
                       description="Compare a model (which holds its base and tool) with measurements: "
                                   "n, rms, mean, max, p95 of the position errors in mm.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", help="model YAML or catalog name")
    p.add_argument("data", help="canonical measurement CSV")
    p.add_argument("--fit-frame", action="store_true",
                   help="first fit only the base frame and SMR offsets (for a nominal model)")
    p.add_argument("--json", metavar="OUT", help="write the statistics as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    import json

    from robocal.data.measurements import Measurements
    from robocal.evaluate import evaluate
    from robocal.io import write_atomic
    from robocal.kinematics.model import load_model

    robot = load_model(args.model)
    data = Measurements.load(args.data, robot=robot)
    stats = evaluate(robot, data, fit_frame=args.fit_frame)
    keys = ("n", "rms", "mean", "max", "p95")
    summary = {k: stats[k] for k in keys}
    out = {"model": args.model, "data": args.data, "kind": stats["kind"], "n_poses": stats["n_poses"],
           "fit_frame": bool(args.fit_frame), "units": "mm", "evaluation": summary,
           "errors_mm": stats["errors_mm"].tolist()}
    if "rotation_deg" in stats:
        out["rotation_deg"] = stats["rotation_deg"]
    if args.json:
        write_atomic(args.json, json.dumps(out, indent=2) + "\n")
    if not args.quiet:
        print(f"{stats['kind']} errors of {args.model} on {args.data} ({stats['n_poses']} poses): "
              + ", ".join(f"{k} {summary[k]:.4f} mm" if k != "n" else f"n {summary[k]}" for k in keys))
        if args.json:
            print(f"wrote {args.json}")
    return 0
