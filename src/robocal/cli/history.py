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
    import json

    from robocal.cli.args import check_format
    from robocal.cli.history_options import check_history_options
    from robocal.core.errors import DataError
    from robocal.core.io import check_outputs, write_all
    from robocal.core.version import __version__
    from robocal.history.store import History, is_postgres

    check_format(args.json, "JSON", "--json")
    check_format(args.report, "HTML", "--report")
    check_outputs([args.json, args.report], [] if is_postgres(args.history) else [args.history])
    check_history_options(args, existing=True)
    robot_id = args.robot_id
    with History(args.history) as history:
        records = history.entries(robot_id)
    if not records:
        raise DataError(f"the history has no record of robot id {robot_id!r}")
    timeline = {"robot_id": robot_id, "entries": [r.timeline_entry() for r in records]}
    texts = {}
    if args.json:
        texts[args.json] = json.dumps(timeline, indent=2, allow_nan=False) + "\n"
    if args.report:
        from robocal.report.timeline import render_history

        texts[args.report] = render_history(timeline, __version__)
    write_all(texts)
    for e in timeline["entries"]:
        held, rms = ("-" if v is None else f"{v:.4f}" for v in (e["held_out_rms"], e["rms"]))
        line = f"#{e['id']:<4} {e['date']}  {e['kind']:<11} held-out {held} mm  RMS {rms} mm"
        if e["kind"] == "check":
            line += f"  {e['verdict']} (p = {e['p_value']:.3g})"
        print(line)
    for path in texts:
        print(f"wrote {path}")
    return 0
