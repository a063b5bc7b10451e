"""``robocal import``: raw tracker/controller exports -> canonical measurement CSV."""

from __future__ import annotations

import argparse

EPILOG = """Column specs are [FILE:]cols=A-B:UNIT (0-based columns; UNIT deg|rad for joints, mm|m for points).

Examples:
  # Meca500: 7 files, joints in columns 0-5 (deg), points in 6-8 (m), 3 readings per pose averaged
  robocal import ../shared/datasets/meca500-faro/cal_data__*.csv \\
      --joints cols=0-5:deg --points cols=6-8:m -o meca_cal.csv
  # IRB 120: one joints file and one file per SMR (mm), base SMRs as drift monitors
  robocal import --joints measured_joints.txt:cols=0-5:deg \\
      --points measured_SMR_1.txt:mm --points measured_SMR_2.txt:mm --points measured_SMR_3.txt:mm \\
      --base measured_base_1.txt:mm -o irb120.csv
"""


def add_parser(sub) -> None:
    p = sub.add_parser("import", help="import raw tracker exports into a measurement CSV",
                       description="Read headerless tracker/controller files with column roles and units "
                                   "given as options; average repeated readings, drop failed ones, "
                                   "write the canonical measurement CSV.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("raw", nargs="*", help="raw files holding joints and points on each row (concatenated)")
    p.add_argument("--joints", required=True, metavar="SPEC", help="joint columns: [FILE:]cols=A-B:deg|rad")
    p.add_argument("--points", required=True, action="append", metavar="SPEC",
                   help="point columns: [FILE:]cols=A-B:mm|m; repeat once per SMR file (SMR 0, 1, ...)")
    p.add_argument("--base", action="append", default=[], metavar="SPEC",
                   help="drift-monitor SMR file on the robot base, FILE[:cols=A-B]:mm|m (report only)")
    p.add_argument("--keep-repeats", action="store_true",
                   help="keep repeated readings as rows sharing a pose_id instead of averaging them")
    p.add_argument("--skip-rows", type=int, default=0, metavar="K", help="header lines to skip in every file")
    p.add_argument("-o", "--output", required=True, help="canonical measurement CSV to write")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.cli.args import check_format, print_warnings
    from robocal.core.io import check_outputs
    from robocal.data.importer import import_tracker
    from robocal.data.inputs import check_distinct_inputs

    specs = [spec.split(":cols=")[0] for spec in [args.joints, *args.points, *args.base] if ":" in spec]
    check_format(args.output, "CSV", "-o")
    check_outputs([args.output], [*args.raw, *specs])
    check_distinct_inputs(args.raw, "raw files")
    result = import_tracker(args.raw, joints=args.joints, points=args.points, base=args.base,
                            average=not args.keep_repeats, skip_rows=args.skip_rows)
    written = result.write(args.output)
    if args.quiet:
        print_warnings("import", result.warnings)
    else:
        print(result.summary())
        print(f"wrote {', '.join(written)}")
    return 0
