"""``robocal import-calibration``: a robot's own factory calibration as a robocal model."""

from __future__ import annotations

import argparse

EPILOG = """Examples:
  robocal import-calibration calibration.conf --robot ur5e -o factory.yaml   # the controller's file
  robocal import-calibration ur10e_calibration.yaml --robot ur10e -o ros.yaml  # what ROS uses
  robocal filter pick.script --calibrated cal.yaml --nominal factory.yaml -o pick_cal.script

calibration.conf is on the UR controller (/root/.urcontrol/calibration.conf, over SFTP); the
ur_calibration YAML is what the ROS driver's calibration_correction writes. The result is the arm the
controller (calibration.conf) or ROS (YAML) computes with, in the catalog robot's joint convention,
from the controller's base frame to its flange (tool0): use it as --robot or --nominal anywhere."""


def add_parser(sub) -> None:
    p = sub.add_parser("import-calibration", help="read a UR factory calibration (calibration.conf or "
                                                  "ur_calibration YAML) as a model YAML",
                       description="Read Universal Robots' factory calibration -- the controller's "
                                   "calibration.conf (DH + deltas) or the ROS driver's ur_calibration YAML "
                                   "(as ur_description's xacro composes it) -- and write it as a model YAML "
                                   "in MDH + beta, exact to the file's own composition.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("calibration", help="calibration.conf or ur_calibration YAML")
    p.add_argument("--robot", required=True,
                   help="the catalog UR robot it calibrates (ur3, ur5e, ur10e, ...): the nominal DH the "
                        "deltas add to, the joint limits and the parameter structure")
    p.add_argument("--name", help="the model's name (default: ROBOT-factory, or ROBOT-ros for a YAML)")
    p.add_argument("-o", "--output", required=True, help="model YAML to write")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.cli.args import check_format
    from robocal.core.io import check_outputs
    from robocal.kinematics.manufacturer.ur import import_calibration

    check_format(args.output, "YAML", "-o")
    check_outputs([args.output], [args.calibration])
    result = import_calibration(args.calibration, args.robot, args.name)
    result.write(args.output)
    for note in result.notes:
        print(f"note: {note}")
    if not args.quiet:
        print(f"{result.robot.name}: {result.kind} {args.calibration} read for {args.robot} (exact to "
              f"its own composition); wrote {args.output}")
    return 0
