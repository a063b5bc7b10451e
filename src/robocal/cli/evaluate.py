"""``robocal evaluate``: position error statistics of a model against measurements."""

from __future__ import annotations

import argparse

from robocal.cli.args import add_fanuc_coupled
from robocal.cli.history_options import add_history_options

EPILOG = """Examples:
  robocal evaluate calibrated.yaml validation.csv --json val.json
  robocal evaluate meca500 meca_val.csv --fit-frame                   # nominal model: fit base and SMRs first
  robocal evaluate meca500 meca_val.csv --frame-from meca_cal.csv     # fit them on one file, judge another
"""


_ERRORS = "<errors_mm>"  # stands for the per-row error list in the JSON until it is written


def add_parser(sub) -> None:
    p = sub.add_parser("evaluate", help="position error statistics of a model on measurements",
                       description="Compare a model (which holds its base and tool) with measurements: "
                                   "n, rms, mean, max, p95 of the position errors in mm.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", help="model YAML or catalog name")
    p.add_argument("data", help="canonical measurement CSV")
    frame = p.add_mutually_exclusive_group()
    frame.add_argument("--fit-frame", action="store_true",
                       help="first fit only the base frame and SMR offsets on DATA (for a nominal model)")
    frame.add_argument("--frame-from", metavar="FIT.csv",
                       help="fit the base frame and SMR offsets on FIT.csv and judge DATA with them")
    p.add_argument("--json", metavar="OUT", help="write the statistics as JSON")
    p.add_argument("--force", action="store_true",
                   help="report statistics the plausibility checks refuse (errors beyond any robot's)")
    add_history_options(p, "record the evaluation (its RMS as the model's held-out error) in this history: a "
                           "SQLite file or a postgresql:// URL; needs --robot-id")
    add_fanuc_coupled(p)
    p.set_defaults(func=run)


def run(args) -> int:
    import json

    from robocal.calibration.evaluation import evaluate
    from robocal.cli.args import check_format, diagnosed, load_measurements
    from robocal.core.errors import PlausibilityError
    from robocal.core.io import check_outputs, write_all
    from robocal.kinematics.model import load_model

    check_format(args.json, "JSON", "--json")
    check_outputs([args.json], [args.model, args.data, args.frame_from])
    from robocal.cli.history_options import check_history_options

    check_history_options(args)
    robot = load_model(args.model)
    from robocal.core.resources import EVALUATION_ADVICE, check_memory, evaluation_bytes
    from robocal.data.csv_table import count_lines

    rows = sum(count_lines(p) for p in (args.data, args.frame_from) if p is not None)  # before reading them
    check_memory(evaluation_bytes(rows), f"evaluating {rows:,} measurement rows", EVALUATION_ADVICE)
    data = load_measurements(args.data, robot, args.quiet, args.fanuc_coupled)
    frame_from = None if args.frame_from is None else \
        load_measurements(args.frame_from, robot, args.quiet, args.fanuc_coupled)
    try:
        stats = evaluate(robot, data, fit_frame=args.fit_frame, frame_from=frame_from, force=args.force)
    except PlausibilityError as exc:
        fitted = args.fit_frame or frame_from is not None
        raise diagnosed(exc, robot, [d for d in (frame_from, data) if d is not None], fitted) from None
    keys = ("n", "rms", "mean", "max", "p95")
    summary = {k: stats[k] for k in keys}
    out = {"model": args.model, "data": args.data, "kind": stats["kind"], "n_poses": stats["n_poses"],
           "fit_frame": bool(args.fit_frame), "frame_from": args.frame_from, "units": "mm",
           "evaluation": summary, "errors_mm": stats["errors_mm"].tolist(),
           "consistency": stats["consistency"], "warnings": stats["warnings"]}
    if "rotation_deg" in stats:
        out["rotation_deg"] = stats["rotation_deg"]
    if args.json:  # the per-row errors on one line by json's C encoder (indent runs the pure-Python one)
        text = json.dumps({**out, "errors_mm": _ERRORS}, indent=2)
        write_all({args.json: text.replace(f'"{_ERRORS}"', json.dumps(out["errors_mm"]), 1) + "\n"})
    for warning in stats["warnings"]:
        print(f"WARNING: {warning}")
    if not args.quiet:
        print(f"{stats['kind']} errors of {args.model} on {args.data} ({stats['n_poses']} poses): "
              + ", ".join(f"{k} {summary[k]:.4f} mm" if k != "n" else f"n {summary[k]}" for k in keys))
        if args.json:
            print(f"wrote {args.json}")
    if args.history:  # after the files: the history is never the only copy
        from robocal.cli.history_options import record_evaluation

        files = [(args.data, "evaluation")] + ([(args.frame_from, "frame")] if args.frame_from else [])
        record_evaluation(args, robot, {**summary, "n_poses": stats["n_poses"], "kind": stats["kind"],
                                        "fit_frame": bool(args.fit_frame)}, files)
    return 0
