"""``robocal demo``: the whole pipeline on the campaign shipped with the package."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub) -> None:
    p = sub.add_parser("demo", help="the whole pipeline on shipped data",
                       description="Calibrate a simulated ABB IRB 2600 tracker campaign shipped with "
                                   "robocal (lsq and robust), validate, compensate targets, plan a "
                                   "joint path, and write the model, the result JSON and the report.",
                       epilog="Example: robocal demo --out robocal-demo",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default="robocal-demo", help="output folder (default ./robocal-demo)")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.demo import run_demo

    run_demo(Path(args.out), quiet=args.quiet)
    return 0
