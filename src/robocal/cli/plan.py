"""``robocal plan``: globally optimal IK branch choice along a trajectory (seed 001)."""

from __future__ import annotations

import argparse

EPILOG = """Examples:
  robocal plan --robot abb_irb2600 poses.csv -o joints.csv
  robocal plan --robot abb_irb2600 poses.csv --weights 2,2,2,1,1,1 --start 0,0,0,0,30,0 -o joints.csv
poses.csv: x_mm,y_mm,z_mm (or _m) and qw,qx,qy,qz or rx_deg,ry_deg,rz_deg (fixed-axis XYZ), one
waypoint per row in order. joints.csv: q1_deg..q6_deg. Default weights: 1 + lever arm (m) of
joints 1-3, 1 for the wrist."""


def _floats(text: str) -> list[float]:
    from robocal.errors import DataError

    try:
        return [float(v) for v in text.replace(" ", "").split(",") if v]
    except ValueError as exc:
        raise DataError(f"expected comma-separated numbers, got {text!r}") from exc


def add_parser(sub) -> None:
    p = sub.add_parser("plan", help="globally optimal joint path through Cartesian waypoints",
                       description="Closed-form IK of every waypoint, candidates inside the joint "
                                   "limits, Dijkstra over the layered graph: minimal weighted joint "
                                   "travel over the whole path. Prints the optimal and greedy costs.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("poses", help="waypoints CSV")
    p.add_argument("--robot", required=True, help="catalog name or model YAML with an OPW form")
    p.add_argument("--weights", help="w1,...,w6 (cost per rad of each joint)")
    p.add_argument("--start", help="fixed start configuration q1..q6 in deg")
    p.add_argument("-o", "--output", required=True, help="joints CSV to write")
    p.set_defaults(func=run)


def run(args) -> int:
    import numpy as np

    from robocal.compensate import format_csv, read_poses_csv
    from robocal.ik.path import plan_path
    from robocal.io import check_outputs, write_atomic
    from robocal.kinematics.model import load_model

    check_outputs([args.output], [args.poses, args.robot])
    robot = load_model(args.robot)
    poses, _ = read_poses_csv(args.poses)
    weights = None if args.weights is None else _floats(args.weights)
    start = None if args.start is None else np.deg2rad(_floats(args.start))
    res = plan_path(robot, poses, weights=weights, start=start)
    cols = [f"q{i + 1}_deg" for i in range(robot.n_joints)]
    write_atomic(args.output, format_csv(cols, np.rad2deg(res.joints)))
    gain = 100.0 * (1.0 - res.cost / res.greedy_cost) if res.greedy_cost > 0 else 0.0
    print(f"weights {np.round(res.weights, 4).tolist()}")
    print(f"optimal total weighted travel {res.cost:.6g}")
    print(f"greedy  total weighted travel {res.greedy_cost:.6g} (optimal saves {gain:.1f}%)")
    return 0
