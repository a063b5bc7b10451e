"""``robocal history``: a robot's calibrations, checks and evaluations in recording order."""

from __future__ import annotations

import argparse

EPILOG = """Examples:
  robocal history robots.sqlite --robot-id IRB-17
  robocal history postgresql://cell@db.example/robocal --robot-id IRB-17 --json timeline.json \
      --report history.html
"""


def add_parser(sub) -> None:
    p = sub.add_parser("history", help="a robot's calibrations and checks over time",
                       description="The timeline of one robot id in a history: each record's kind, date "
                                   "(UTC), held-out RMS, check verdict and p-value, and its data's SHA-256.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("history", metavar="PATH_OR_URL", help="the history: a SQLite file or a postgresql:// URL")
    p.add_argument("--robot-id", metavar="ID", required=True, help="the robot's id in the history")
    p.add_argument("--json", metavar="out.json", help='write the timeline as JSON ({"entries": [...]})')
    p.add_argument("--report", metavar="history.html",
                   help="write an HTML page with the held-out and check RMS over time")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.cli.args import check_format
    from robocal.core.io import check_outputs
    from robocal.history.record import open_history
    from robocal.history.store import is_postgres
    from robocal.history.timeline import read_timeline

    check_format(args.json, "JSON", "--json")
    check_format(args.report, "HTML", "--report")
    check_outputs([args.json, args.report], [] if is_postgres(args.history) else [args.history])
    result = read_timeline(args.history, open_history(args.history, args.robot_id, existing=True,
                                                      writes=False))
    written = result.write(args.json, args.report)
    for warning in result.warnings:
        print(f"WARNING: {warning}")
    print(result.summary())
    for path in written:
        print(f"wrote {path}")
    return 0
