"""``robocal demo``: a catalog robot's parameter table and its flange pose at a few joint sets."""

from __future__ import annotations

import argparse

import numpy as np

DEMO_JOINTS_DEG = np.array([[0, 0, 0, 0, 0, 0], [30, -20, 15, 45, -60, 90], [-90, 40, -30, -120, 30, 0]],
                           dtype=float)


def add_parser(sub) -> None:
    p = sub.add_parser("demo", help="show a catalog robot: parameters and flange poses",
                       description="Load a catalog robot, print its MDH + beta parameter table (mm, deg) "
                                   "and its flange pose at a few joint sets.",
                       epilog="Example: robocal demo --robot kuka_kr16_2",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--robot", default="abb_irb2600", help="catalog name (default abb_irb2600)")
    p.set_defaults(func=run)


def run(args) -> int:
    import warnings

    from scipy.spatial.transform import Rotation

    from robocal import Robot

    robot = Robot.from_catalog(args.robot)
    print(f"{robot.name}: {robot.description}")
    print("\nmodified DH + beta (T_i = Rx(alpha) Tx(a) Ry(beta) Rz(theta + q) Tz(d))")
    print(f"{'joint':>5} {'alpha deg':>10} {'a mm':>10} {'beta deg':>9} {'theta deg':>10} {'d mm':>10}"
          f"  {'limits deg':>17}  parallel")
    for i in range(robot.n_joints):
        lo, hi = np.rad2deg(robot.limits[i])
        print(f"{i + 1:5d} {np.rad2deg(robot.alpha[i]):10.3f} {robot.a[i] * 1e3:10.3f} "
              f"{np.rad2deg(robot.beta[i]):9.3f} {np.rad2deg(robot.theta[i]):10.3f} {robot.d[i] * 1e3:10.3f}"
              f"  {lo:8.1f} {hi:8.1f}  {'yes' if robot.parallel[i] else ''}")
    for label, T in (("base", robot.base), ("tool", robot.tool)):
        rpy = Rotation.from_matrix(T[:3, :3]).as_euler("xyz", degrees=True)
        print(f"{label}: xyz {np.round(T[:3, 3] * 1e3, 3).tolist()} mm, rpy {np.round(rpy, 3).tolist()} deg")
    q = DEMO_JOINTS_DEG[:, : robot.n_joints]
    T = robot.fk(np.deg2rad(q))
    with warnings.catch_warnings():  # gimbal lock at pitch +-90 deg: scipy then sets yaw to 0
        warnings.simplefilter("ignore", UserWarning)
        rpy = Rotation.from_matrix(T[:, :3, :3]).as_euler("xyz", degrees=True)
    print("\nflange pose (x y z mm, fixed-axis roll pitch yaw deg)")
    for k in range(len(q)):
        print(f"q = {np.array2string(q[k], precision=1, separator=', ')} deg  ->  "
              f"xyz {np.array2string(T[k, :3, 3] * 1e3, precision=3, separator=', ')}  "
              f"rpy {np.array2string(rpy[k], precision=3, separator=', ')}")
    return 0
