"""``robocal plan``: globally optimal IK branch choice along a trajectory."""

from __future__ import annotations

import argparse

from robocal.cli.args import check_format, numbers

EPILOG = """Examples:
  robocal plan --robot abb_irb2600 poses.csv -o joints.csv
  robocal plan --robot abb_irb2600 poses.csv --weights 2,2,2,1,1,1 --start 0,0,0,0,30,0 -o joints.csv
  robocal plan --robot calibrated.yaml --nominal abb_irb2600 --tool 50,0,200,0,30,0 poses.csv -o joints.csv
poses.csv: x_mm,y_mm,z_mm (or _m) and qw,qx,qy,qz or rx_deg,ry_deg,rz_deg (fixed-axis XYZ), one
waypoint per row in order. joints.csv: q1_deg..q6_deg. Default weights: 1 + lever arm (m) of
joints 1-3, 1 for the wrist. A calibrated model (with --nominal, the controller's model; default the
catalog robot of the model's name) is planned in the robot's base frame (its identified frame {0})
with its flange (tool0) carrying --tool (x,y,z,rx,ry,rz, mm, deg, fixed-axis XYZ; default: none, the
poses are flange poses; --tool measured: the model's own tool, e.g. the measured SMR); candidates are
the nominal closed form in each branch refined by numeric IK on the calibrated model."""


def add_parser(sub) -> None:
    p = sub.add_parser("plan", help="globally optimal joint path through Cartesian waypoints",
                       description="Closed-form IK of every waypoint, candidates inside the joint "
                                   "limits, Dijkstra over the layered graph: minimal weighted joint "
                                   "travel over the whole path. Prints the optimal and greedy costs.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("poses", help="waypoints CSV")
    p.add_argument("--robot", required=True,
                   help="catalog name or model YAML with a closed form (OPW, UR, SCARA)")
    p.add_argument("--weights", type=numbers(None, "w1,...,wn"),
                   help="w1,...,wn (cost per rad of each joint; per m on a SCARA's quill)")
    p.add_argument("--start", type=numbers(None, "q1,...,qn in deg"),
                   help="fixed start configuration q1..qn in deg (mm on a SCARA's quill)")
    p.add_argument("--nominal",
                   help="the controller's model (catalog name or YAML) when --robot is calibrated")
    p.add_argument("--tool", metavar="x,y,z,rx,ry,rz", default="flange",
                   help="the TCP of the poses: flange (default, tool0), the user's tool on the flange "
                        "x,y,z,rx,ry,rz (mm, deg), or measured (the model's own tool, e.g. the SMR)")
    p.add_argument("-o", "--output", required=True, help="joints CSV to write")
    p.set_defaults(func=run)


def run(args) -> int:
    import numpy as np

    from robocal.core.io import check_outputs
    from robocal.data.measurements import robot_reach
    from robocal.deploy.compensation import check_target_units, read_poses_csv
    from robocal.deploy.models import controller_for, planning_model
    from robocal.ik import track
    from robocal.ik.path import plan_path
    from robocal.kinematics.cell import is_track_cell
    from robocal.kinematics.model import load_model

    check_format(args.output, "CSV", "-o")
    check_outputs([args.output], [args.poses, args.robot])
    robot = load_model(args.robot)
    nominal = controller_for(robot, args.nominal)
    robot, frames = planning_model(robot, nominal, args.tool)
    poses, layout = read_poses_csv(args.poses)
    check_target_units(poses, layout, robot_reach(robot), args.poses, robot.base[:3, 3])
    start = None if args.start is None or len(args.start) != robot.n_joints else \
        np.where(robot.prismatic, np.asarray(args.start) * 1e-3, np.deg2rad(args.start))  # mm on a quill
    start = np.deg2rad(args.start) if args.start is not None and start is None else start  # an arm on a track
    # an arm on a track: the carriage where the poses put it (without e1 values plan_path refuses)
    if is_track_cell(robot) and "e1" in layout:
        start = None if start is None else np.r_[layout["e1"][0], start]
        res = track.plan(robot, poses, layout["e1"], weights=args.weights, start=start, nominal=nominal)
    else:
        res = plan_path(robot, poses, weights=args.weights, start=start, nominal=nominal)
    res.write(args.output)
    print(f"poses: {frames}")
    print(res.summary())
    return 0
