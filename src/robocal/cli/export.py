"""``robocal export``: a model (YAML, catalog name or URDF) as URDF and/or model YAML."""

from __future__ import annotations

import argparse

EPILOG = """Examples:
  robocal export calibrated.yaml --urdf calibrated.urdf      # calibrated model for ROS
  robocal export abb_irb2600 --urdf irb2600.urdf             # catalog robot
  robocal export my_robot.urdf --yaml my_robot.yaml          # import a serial revolute URDF
"""


def add_parser(sub) -> None:
    p = sub.add_parser("export", help="export a model as URDF (or import a URDF as model YAML)",
                       description="Write a robot model as URDF whose forward kinematics from `world` "
                                   "to `tool0` equals the model's (base and tool as fixed joints), or "
                                   "convert a serial revolute URDF into a model YAML (MDH + beta).",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", help="model YAML, catalog name, or URDF file (.urdf)")
    p.add_argument("--urdf", metavar="OUT", help="URDF file to write")
    p.add_argument("--yaml", metavar="OUT", help="model YAML file to write")
    p.add_argument("--tip", help="URDF input: end link of the chain (default: the deepest leaf)")
    p.set_defaults(func=run)


def run(args) -> int:
    from pathlib import Path

    from robocal.errors import DataError
    from robocal.io import check_outputs, write_all
    from robocal.kinematics.model import load_model
    from robocal.kinematics.model_file import dump_model
    from robocal.kinematics.urdf import from_urdf, not_carried, to_urdf

    if not args.urdf and not args.yaml:
        raise DataError("nothing to write: give --urdf OUT and/or --yaml OUT")
    check_outputs([args.urdf, args.yaml], [args.model])
    if Path(args.model).suffix.lower() == ".urdf":
        robot = from_urdf(Path(args.model), tip=args.tip)
    else:
        robot = load_model(args.model)
    texts = {}
    if args.urdf:
        texts[args.urdf] = to_urdf(robot)
        if not_carried(robot):
            print(f"WARNING: {not_carried(robot)}")
    if args.yaml:
        texts[args.yaml] = dump_model(robot)
    write_all(texts)
    if not args.quiet:
        print(f"{robot.name} ({robot.n_joints} joints): wrote {', '.join(texts)}")
    return 0
