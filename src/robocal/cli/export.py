"""``robocal export``: a model (YAML, catalog name or URDF) as URDF and/or model YAML."""

from __future__ import annotations

import argparse

EPILOG = """Examples:
  robocal export calibrated.yaml --urdf calibrated.urdf      # calibrated model for ROS (base_link, tool0)
  robocal export calibrated.yaml --urdf measured.urdf --frames model   # world = tracker frame, tool0 = SMR
  robocal export abb_irb2600 --urdf irb2600.urdf             # catalog robot
  robocal export my_robot.urdf --yaml my_robot.yaml          # import a serial revolute URDF
  robocal export calibrated.yaml --nominal factory.yaml --ur-calibration ur.yaml   # for the UR ROS driver
  robocal export calibrated.yaml --urdf-like kr16_2.urdf -o kr16_2_cal.urdf   # into the vendor's URDF
  robocal export calibrated.yaml --urdf-like kr16_2.urdf -o cal.urdf --xacro kr16_2_macro.xacro macro.xacro
"""


def add_parser(sub) -> None:
    p = sub.add_parser("export", help="export a model as URDF (or import a URDF as model YAML)",
                       description="Write a robot model as URDF for ROS: root `base_link` at the robot's "
                                   "base, `tool0` at the flange, the (calibrated) geometry in between; "
                                   "the model's measurement frame and tool (tracker frame, SMR) in a "
                                   "comment, or as the URDF's `world` and `tool0` with --frames model. "
                                   "Or convert a serial revolute URDF into a model YAML (MDH + beta). "
                                   "Or, with --urdf-like, write the vendor's own URDF (and xacro macro) "
                                   "with the calibrated kinematics.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", help="model YAML, catalog name, or URDF file (.urdf)")
    p.add_argument("--urdf", metavar="OUT", help="URDF file to write")
    p.add_argument("--yaml", metavar="OUT", help="model YAML file to write")
    p.add_argument("--ur-calibration", metavar="OUT",
                   help="ur_calibration YAML to write (Universal Robots: the geometry from the controller's "
                        "base to the flange, as ur_description's xacro composes it)")
    p.add_argument("--urdf-like", metavar="VENDOR",
                   help="the vendor's expanded URDF (ROS-Industrial support package, ur_description): write "
                        "the same document (names, meshes, limits, extra frames) with the calibrated "
                        "kinematics to -o; only its moving joints' origins change (checked against "
                        "--nominal: refused when it describes another robot)")
    p.add_argument("-o", "--output", metavar="OUT", help="--urdf-like: the URDF file to write")
    p.add_argument("--xacro", nargs=2, metavar=("MACRO", "OUT"),
                   help="--urdf-like: also the vendor's xacro macro the URDF was expanded from (a "
                        "ROS-Industrial *_macro.xacro) written to OUT with the calibrated joint origins")
    p.add_argument("--vendor-model", metavar="R",
                   help="--urdf-like: the nominal model the vendor's file draws when --nominal is not it "
                        "(e.g. --nominal factory.yaml, a UR's factory calibration, --vendor-model ur5e)")
    p.add_argument("--joint-map", action="append", metavar="NAME=SIGN,OFFSET_DEG",
                   help="--urdf-like: a vendor joint's value as SIGN * the controller's + OFFSET (repeat per "
                        "joint; default: found from the axes), e.g. joint_a4=1,-90")
    p.add_argument("--geometry-only", action="store_true",
                   help="--urdf-like: write the geometry of a model whose joint-error terms (compliance, "
                        "backlash...) matter, which a URDF cannot hold (refused otherwise)")
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

    if args.urdf_like or args.output or args.xacro:
        return _urdf_like(args)
    from robocal.cli.args import check_format
    from robocal.core.errors import DataError
    from robocal.core.io import check_outputs
    from robocal.deploy.formats import export_model
    from robocal.kinematics.model import load_model

    if not args.urdf and not args.yaml and not args.ur_calibration:
        raise DataError("nothing to write: give --urdf OUT, --yaml OUT and/or --ur-calibration OUT")
    check_format(args.urdf, "URDF", "--urdf")
    check_format(args.yaml, "YAML", "--yaml")
    check_format(args.ur_calibration, "YAML", "--ur-calibration")
    check_outputs([args.urdf, args.yaml, args.ur_calibration], [args.model])
    robot = load_model(args.model, tip=args.tip)
    result = export_model(robot, args.urdf, args.yaml, args.ur_calibration, args.frames, args.nominal)
    for line in result.lines(args.quiet):
        print(line)
    written = result.write()
    if not args.quiet:
        print(f"{robot.name} ({robot.n_joints} joints): wrote {', '.join(written)}")
    return 0


def _urdf_like(args) -> int:
    """``--urdf-like VENDOR -o OUT``: the vendor's URDF with the calibrated kinematics."""
    from robocal.cli.args import check_format
    from robocal.core.errors import DataError
    from robocal.deploy.urdf_like import export_urdf_like, parse_joint_map

    if not args.urdf_like or not args.output:
        raise DataError("--urdf-like VENDOR and -o OUT go together: the vendor's URDF and the file to write")
    if args.urdf or args.yaml or args.ur_calibration:
        raise DataError("--urdf-like writes one file (-o OUT): run --urdf, --yaml or --ur-calibration apart")
    check_format(args.output, "URDF", "-o")
    macro, macro_out = args.xacro or (None, None)
    # the API refuses writing over the model file, the vendor's files (export_urdf_like, write)
    result = export_urdf_like(args.model, args.urdf_like, nominal=args.nominal, output=args.output,
                              tip=args.tip, xacro=macro, xacro_output=macro_out,
                              geometry_only=args.geometry_only, vendor_model=args.vendor_model,
                              joint_map=parse_joint_map(args.joint_map) if args.joint_map else None)
    if not args.quiet:
        print(result.summary())
    for line in result.warnings:
        print(f"WARNING: {line}")
    result.write()
    return 0
