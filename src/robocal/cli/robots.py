"""``robocal robots [NAME]``: list the robot catalog, or show one robot's model."""

from __future__ import annotations

import argparse


def add_parser(sub) -> None:
    p = sub.add_parser("robots", help="list the robot catalog or show one robot",
                       description="Without NAME: the catalog's robots with a one-line description, "
                                   "then its positioners. With NAME (a catalog robot or positioner, or a "
                                   "model YAML): its MDH + beta table "
                                   "(mm, deg), frames, limits and the flange pose at a few joint sets.",
                       epilog="Examples:\n  robocal robots\n  robocal robots kuka_kr16_2\n"
                              "  robocal robots abb_irbp_a250",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("name", nargs="?", help="a catalog name or a model YAML to show")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.kinematics.listing import catalog_listing, describe

    print(catalog_listing() if args.name is None else describe(args.name))
    return 0
