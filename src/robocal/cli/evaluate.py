"""``robocal evaluate``: position error statistics of a model against measurements."""

from __future__ import annotations

import argparse

from robocal.cli.args import INSTRUMENT_NAMES, add_fanuc_coupled
from robocal.cli.history_options import add_history_options

EPILOG = """Examples:
  robocal evaluate calibrated.yaml validation.csv --json val.json
  robocal evaluate calibrated.yaml validation.csv --result result.json   # judged against its prediction
  robocal evaluate meca500 meca_val.csv --fit-frame                   # nominal model: fit base and SMRs first
  robocal evaluate meca500 meca_val.csv --frame-from meca_cal.csv     # fit them on one file, judge another
  robocal evaluate calibrated_cell.yaml cell_check.csv --json check.json   # a work cell: one tracker frame
      # fitted for every body's SMRs (the rows' body column), the SMRs' places fitted except plate nests
"""


def add_parser(sub) -> None:
    p = sub.add_parser("evaluate", help="position error statistics of a model on measurements",
                       description="Compare a model (which holds its base and tool) with measurements: "
                                   "n, rms, mean, max, p95 of the position errors in mm.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", help="model YAML or catalog name, or a work cell file (arms, positioners)")
    p.add_argument("data", help="canonical measurement CSV")
    frame = p.add_mutually_exclusive_group()
    frame.add_argument("--fit-frame", action="store_true",
                       help="first fit only the base frame and SMR offsets on DATA (for a nominal model)")
    frame.add_argument("--frame-from", metavar="FIT.csv",
                       help="fit the base frame and SMR offsets on FIT.csv and judge DATA with them")
    p.add_argument("--json", metavar="OUT", help="write the statistics as JSON")
    p.add_argument("--result", metavar="RESULT.json",
                   help="the result JSON of the calibration that made MODEL (calibrate --json): judge point "
                        "or pose data against its accuracy prediction at their poses (as calibrate "
                        "--validate)")
    p.add_argument("--instrument", choices=INSTRUMENT_NAMES,
                   help="the instrument that took DATA if it declares none: its documented noise is the "
                        "consistency test's")
    p.add_argument("--force", action="store_true",
                   help="report statistics the plausibility checks refuse (errors beyond any robot's)")
    add_history_options(p, "record the evaluation (its RMS as the model's held-out error) in this history: a "
                           "SQLite file or a postgresql:// URL; needs --robot-id")
    add_fanuc_coupled(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.calibration.evaluation import check_files_memory, evaluate
    from robocal.cli.args import check_format, load_measurements, work_cell
    from robocal.core.io import check_outputs
    from robocal.history.record import evaluation_record, open_history, record_entry
    from robocal.kinematics.model import load_model

    check_format(args.json, "JSON", "--json")
    check_outputs([args.json], [args.model, args.data, args.frame_from, args.result])
    robot_id = open_history(args.history, args.robot_id, outputs=[args.json])
    if (cell := work_cell(args.model)) is not None:  # every body in one tracker frame
        return _evaluate_cell(args, cell)
    robot = load_model(args.model)
    check_files_memory([args.data, args.frame_from])  # before reading them
    data = load_measurements(args.data, robot, args.quiet, args.fanuc_coupled)
    frame_from = None if args.frame_from is None else \
        load_measurements(args.frame_from, robot, args.quiet, args.fanuc_coupled)
    stats = evaluate(robot, data, fit_frame=args.fit_frame, frame_from=frame_from, force=args.force,
                     names={"model": args.model, "data": args.data, "frame_from": args.frame_from},
                     instrument=args.instrument, result=args.result)
    _said(stats, stats.write(args.json), args.quiet)
    if args.history:  # after the files: the history is never the only copy
        files = [(args.data, "evaluation")] + ([(args.frame_from, "frame")] if args.frame_from else [])
        said = record_entry(args.history, evaluation_record(args.history, robot_id, robot, stats, files))
        if not args.quiet:
            print(said)
    return 0


def _evaluate_cell(args, cell) -> int:
    """``evaluate CELL.yaml DATA.csv``: one frame fitted for every body, the statistics per body."""
    import robocal as rc
    from robocal.core.errors import DataError

    unsupported = [o for o, v in (("--fit-frame", args.fit_frame), ("--frame-from", args.frame_from),
                                  ("--history", args.history), ("--result", args.result)) if v]
    if unsupported:
        raise DataError(f"evaluate with a work cell fits one tracker frame for every body itself: not "
                        f"{', '.join(unsupported)}")
    result = rc.evaluate(cell, rc.CellMeasurements.load(args.data, cell))
    _said(result, result.write(args.json) if args.json else [], args.quiet)
    return 0


def _said(result, written: list[str], quiet: bool) -> None:
    """An evaluation's warnings, then (unless ``quiet``) its summary and the files written."""
    for warning in result.warnings:
        print(f"WARNING: {warning}")
    if not quiet:
        print(result.summary())
        for path in written:
            print(f"wrote {path}")
