"""``robocal robots``: list the robot catalog."""

from __future__ import annotations

import argparse


def add_parser(sub) -> None:
    p = sub.add_parser("robots", help="list the robot catalog",
                       description="List the catalog's robots with a one-line description.",
                       epilog="Example: robocal robots",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.kinematics.catalog import catalog_descriptions

    for name, text in catalog_descriptions().items():
        print(f"{name:20s} {text}")
    return 0
