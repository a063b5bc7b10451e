"""``robocal report``: the self-contained HTML report of a calibration result JSON."""

from __future__ import annotations

import argparse

EPILOG = """Example:
  robocal calibrate tracker.csv --robot abb_irb2600 --json result.json
  robocal report result.json -o report.html --title "IRB 2600, cell 4"
"""


def add_parser(sub) -> None:
    p = sub.add_parser("report", help="HTML report of a calibration result JSON",
                       description="Write one self-contained HTML file (inline figures, no network "
                                   "access when opened) from the JSON of `robocal calibrate --json`.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("result", help="result JSON written by `robocal calibrate --json`")
    p.add_argument("-o", "--output", required=True, metavar="HTML", help="report file to write")
    p.add_argument("--title", help="page title (default: 'Calibration report: <robot>')")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.calibration.result import load_result
    from robocal.cli.args import check_format
    from robocal.core.io import check_outputs
    from robocal.report.html import write_report

    check_format(args.output, "HTML", "-o")
    check_outputs([args.output], [args.result])
    path = write_report(load_result(args.result), args.output, title=args.title)
    if not args.quiet:
        print(f"wrote {path}")
    return 0
