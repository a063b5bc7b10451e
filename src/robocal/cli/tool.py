"""``robocal tool``: a real tool's TCP on the calibrated model from poses touching one point."""

from __future__ import annotations

import argparse

EPILOG = """Examples:
  robocal tool touch.csv --calibrated cal.yaml --nominal abb_irb2600
  robocal tool touch.csv --calibrated cal.yaml --nominal abb_irb2600 --name tGun --rotation 0,30,0 \\
      --json tgun.json
touch.csv: q1_deg..q6_deg (or _rad), one row per pose, the TCP touching the same fixed point with the
tool tilted about at least two different axes (30 deg or more; 4 poses at least, more is better).
Prints the TCP in flange coordinates (ROS-I tool0, mm), the touched point, the residual of every
pose, and the --tcp option for robocal filter / compensate / plan."""


def add_parser(sub) -> None:
    p = sub.add_parser("tool", help="identify a tool's TCP on the calibrated model (4-point method)",
                       description="The controllers' 4-point TCP method with the calibrated kinematics: "
                                   "least squares for the TCP in flange coordinates and the fixed point.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("joints", help="CSV of joint positions touching one point")
    p.add_argument("--calibrated", required=True, help="calibrated model YAML")
    p.add_argument("--nominal", required=True, help="catalog name or model YAML (for the flange, tool0)")
    p.add_argument("--robot-base", metavar="x,y,z,rx,ry,rz",
                   help="the controller's base in the calibrated model's world frame (mm, deg)")
    p.add_argument("--name", default="TOOL", help="tool name for the printed --tcp option")
    p.add_argument("--rotation", default="0,0,0", metavar="rx,ry,rz",
                   help="the tool's orientation on the flange (deg, fixed-axis XYZ) for the printed --tcp "
                        "option: the 4-point method finds the position only")
    p.add_argument("--json", help="write the result as JSON here")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.core.io import check_outputs
    from robocal.data.measurements import read_joints, robot_reach
    from robocal.deploy.models import robot_base_frame, tool_rotation
    from robocal.deploy.tcp import identify_tcp
    from robocal.kinematics.model import Robot, load_model

    rotation = tool_rotation(args.rotation, "--rotation")
    check_outputs([args.json], [args.calibrated, args.joints, args.nominal])
    calibrated, nominal = Robot.load(args.calibrated), load_model(args.nominal)
    q = read_joints(args.joints, nominal)
    base = robot_base_frame(args.robot_base, robot_reach(nominal))  # magnitudes checked, as filter's
    res = identify_tcp(calibrated, nominal, q, base)
    res.write(args.json, args.name, rotation)
    print(res.summary())
    print(f"use: --tcp {res.option(args.name, rotation)}")
    return 0
