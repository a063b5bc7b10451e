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
    import json

    from robocal.core.io import check_outputs, write_atomic
    from robocal.core.magnitudes import check_degrees
    from robocal.data.measurements import read_joints
    from robocal.deploy.compensation import frame_from_text, frame_to_text, rotation_from_text
    from robocal.deploy.tcp import identify_tcp
    from robocal.kinematics.model import Robot, load_model
    from robocal.kinematics.transforms import make_transform

    rotation = rotation_from_text(args.rotation, "--rotation")
    angles = [float(v) for v in args.rotation.replace(" ", "").split(",") if v]
    check_degrees(angles, f"--rotation {args.rotation}")
    check_outputs([args.json], [args.calibrated, args.joints, args.nominal])
    calibrated = Robot.load(args.calibrated)
    nominal = load_model(args.nominal)
    q = read_joints(args.joints, nominal)
    base = None if args.robot_base is None else frame_from_text(args.robot_base, "--robot-base")
    res = identify_tcp(calibrated, nominal, q, base)
    T = make_transform(rotation, res.tcp)
    if args.json:
        write_atomic(args.json, json.dumps({
            "tcp_mm": (res.tcp * 1e3).tolist(), "point_mm": (res.point * 1e3).tolist(),
            "residuals_mm": (res.residuals * 1e3).tolist(), "rms_mm": res.rms_mm,
            "spread_deg": res.spread_deg, "tcp_option": f"{args.name}={frame_to_text(T)}"}, indent=1) + "\n")
    print(res.summary())
    print(f"use: --tcp {args.name}={frame_to_text(T)}")
    return 0
