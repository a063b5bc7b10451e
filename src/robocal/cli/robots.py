"""``robocal robots [NAME]``: list the robot catalog, or show one robot's model."""

from __future__ import annotations

import argparse


def add_parser(sub) -> None:
    p = sub.add_parser("robots", help="list the robot catalog or show one robot",
                       description="Without NAME: the catalog's robots with a one-line description. "
                                   "With NAME (catalog name or model YAML): its MDH + beta table "
                                   "(mm, deg), frames, limits and the flange pose at a few joint sets.",
                       epilog="Examples:\n  robocal robots\n  robocal robots kuka_kr16_2",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("name", nargs="?", help="a catalog name or a model YAML to show")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.kinematics.listing import catalog_listing, model_table
    from robocal.kinematics.model import load_model

    print(catalog_listing() if args.name is None else model_table(load_model(args.name)))
    return 0
