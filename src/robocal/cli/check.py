"""``robocal check``: does a calibration still hold? A short campaign judged by a stated test."""

from __future__ import annotations

import argparse

from robocal.cli.history_options import add_history_options

EPILOG = """Examples:
  robocal check calibrated.yaml check.csv --fit-frame --history robots.sqlite --robot-id IRB-17 \
      --json check.json
  robocal check calibrated.yaml check.csv --fit-frame --result result.json --noise-mm 0.02

The calibration's own uncertainty (its covariance) comes from the history (--history, --robot-id:
the calibration recorded with this model) or from its result JSON (--result). The verdict is
"changed" exactly when p_value < 0.01; both verdicts exit 0.
"""


def add_parser(sub) -> None:
    p = sub.add_parser("check", help="judge a calibration on a short check campaign (holds / changed)",
                       description="Refit the tracker frame and SMR offsets, then test the check residuals "
                                   "against the instrument noise plus the calibration's own predicted "
                                   "error; when changed, name what most likely moved (without --fit-frame "
                                   "the SMR or the tracker frame first, then the parameters).",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", metavar="CALIBRATED.yaml", help="the calibrated model (calibrate -o)")
    p.add_argument("data", metavar="CHECK.csv", help="point measurements of the check campaign (10-30 poses)")
    p.add_argument("--fit-frame", action="store_true",
                   help="refit the tracker frame and SMR offsets on the check data (the tracker moved "
                        "since the calibration); without it the model's own frame is used")
    p.add_argument("--result", metavar="RESULT.json",
                   help="the calibration's result JSON (calibrate --json), when it is not in a history")
    p.add_argument("--noise-mm", type=float, metavar="MM",
                   help="the instrument's 1-sigma noise per coordinate (mm); default: the calibration's "
                        "noise estimate, with its uncertainty counted (F-test)")
    p.add_argument("--json", metavar="out.json", help="write the verdict as JSON")
    p.add_argument("--force", action="store_true",
                   help="judge data the plausibility checks refuse (errors beyond any robot's)")
    add_history_options(p, "the history holding the calibration (a SQLite file or postgresql:// URL); the "
                           "check is recorded there too")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.cli.args import check_format, load_measurements
    from robocal.core.io import check_outputs
    from robocal.history.check import check_calibration, load_calibration
    from robocal.history.record import check_record, open_history, record_entry

    check_format(args.json, "JSON", "--json")
    check_outputs([args.json], [args.model, args.data, args.result])
    robot_id = open_history(args.history, args.robot_id, existing=True, outputs=[args.json])
    robot, uncertainty, parent = load_calibration(args.model, args.result, args.history, robot_id)
    data = load_measurements(args.data, robot, args.quiet)
    result = check_calibration(robot, data, uncertainty, fit_frame=args.fit_frame, noise_mm=args.noise_mm,
                               force=args.force)
    for path in result.write(args.json, model=args.model, data=args.data, fit_frame=bool(args.fit_frame),
                             calibration_record=parent):
        print(f"wrote {path}")
    print(result.summary())
    if args.history:
        said = record_entry(args.history, check_record(result, robot_id, robot, args.data, parent))
        if not args.quiet:
            print(said)
    return 0
