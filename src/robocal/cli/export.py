"""``robocal export``: a model (YAML, catalog name or URDF) as URDF and/or model YAML."""

from __future__ import annotations

import argparse

EPILOG = """Examples:
  robocal export calibrated.yaml --urdf calibrated.urdf      # calibrated model for ROS (base_link, tool0)
  robocal export calibrated.yaml --urdf measured.urdf --frames model   # world = tracker frame, tool0 = SMR
  robocal export abb_irb2600 --urdf irb2600.urdf             # catalog robot
  robocal export my_robot.urdf --yaml my_robot.yaml          # import a serial revolute URDF
  robocal export calibrated.yaml --nominal factory.yaml --ur-calibration ur.yaml   # for the UR ROS driver
"""


def add_parser(sub) -> None:
    p = sub.add_parser("export", help="export a model as URDF (or import a URDF as model YAML)",
                       description="Write a robot model as URDF for ROS: root `base_link` at the robot's "
                                   "base, `tool0` at the flange, the (calibrated) geometry in between; "
                                   "the model's measurement frame and tool (tracker frame, SMR) in a "
                                   "comment, or as the URDF's `world` and `tool0` with --frames model. "
                                   "Or convert a serial revolute URDF into a model YAML (MDH + beta).",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", help="model YAML, catalog name, or URDF file (.urdf)")
    p.add_argument("--urdf", metavar="OUT", help="URDF file to write")
    p.add_argument("--yaml", metavar="OUT", help="model YAML file to write")
    p.add_argument("--ur-calibration", metavar="OUT",
                   help="ur_calibration YAML to write (Universal Robots: the geometry from the controller's "
                        "base to the flange, as ur_description's xacro composes it)")
    p.add_argument("--frames", choices=("robot", "model"), default="robot",
                   help="robot (default): base_link at the robot base, tool0 at the flange; model: a "
                        "world link at the model's world frame (after a tracker calibration, the tracker) "
                        "and tool0 at the model's tool (the measured SMR)")
    p.add_argument("--nominal", metavar="R",
                   help="--frames robot: the controller's model (catalog name or YAML) whose base and "
                        "flange (tool0) the URDF takes (default: the catalog robot of the model's name)")
    p.add_argument("--tip", help="URDF input: end link of the chain (default: the deepest leaf)")
    p.set_defaults(func=run)


def run(args) -> int:
    from pathlib import Path

    from robocal.cli.args import check_format
    from robocal.core.errors import DataError
    from robocal.core.io import check_outputs, write_all
    from robocal.deploy.models import controller_for
    from robocal.kinematics.model import load_model
    from robocal.kinematics.model_file import dump_model
    from robocal.kinematics.urdf import from_urdf, not_carried, to_urdf

    if not args.urdf and not args.yaml and not args.ur_calibration:
        raise DataError("nothing to write: give --urdf OUT, --yaml OUT and/or --ur-calibration OUT")
    check_format(args.urdf, "URDF", "--urdf")
    check_format(args.yaml, "YAML", "--yaml")
    check_format(args.ur_calibration, "YAML", "--ur-calibration")
    check_outputs([args.urdf, args.yaml, args.ur_calibration], [args.model])
    if Path(args.model).suffix.lower() == ".urdf":
        robot = from_urdf(Path(args.model), tip=args.tip)
    else:
        robot = load_model(args.model)
    texts = {}
    if args.urdf:
        nominal = controller_for(robot, args.nominal) if args.frames == "robot" else None
        if args.frames == "robot" and nominal is None:
            print(f"note: {robot.name} is not a catalog robot and no --nominal is given: base_link is the "
                  "model's frame {0}, tool0 the flange centre with the model's tool rotation")
        texts[args.urdf] = to_urdf(robot, frames=args.frames, nominal=nominal)
        if not_carried(robot):
            print(f"WARNING: {not_carried(robot)}")
        if not args.quiet:
            print("URDF frames: " + (
                "base_link = the robot's base (frame {0}), tool0 = the flange; the model's world frame "
                "and tool are in a comment (--frames model to use them)" if args.frames == "robot" else
                "world = the model's world frame (e.g. the tracker), tool0 = the model's tool (e.g. the "
                "measured SMR)"))
    if args.yaml:
        texts[args.yaml] = dump_model(robot)
    if args.ur_calibration:
        from robocal.kinematics.manufacturer.ur import not_representable, to_ur_calibration

        nominal = controller_for(robot, args.nominal)
        if nominal is None:
            raise DataError(f"--ur-calibration: {robot.name} is not a catalog robot: give --nominal, the "
                            "controller's model (e.g. ur5e, or factory.yaml from robocal import-calibration)")
        texts[args.ur_calibration] = to_ur_calibration(robot, nominal)
        if not_representable(robot):
            print(f"WARNING: {not_representable(robot)}")
        if not args.quiet:
            print("ur_calibration YAML: the geometry from the controller's base to the flange (tool0); the "
                  "model's world frame and tool are not part of it; its hash is robocal's, so the ROS driver "
                  "reports that it differs from the robot's own calibration")
    write_all(texts)
    if not args.quiet:
        print(f"{robot.name} ({robot.n_joints} joints): wrote {', '.join(texts)}")
    return 0
