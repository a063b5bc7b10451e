"""``robocal robots [NAME]``: list the robot catalog, or show one robot's model."""

from __future__ import annotations

import argparse

import numpy as np

SHOW_JOINTS_DEG = np.array([[0, 0, 0, 0, 0, 0], [30, -20, 15, 45, -60, 90], [-90, 40, -30, -120, 30, 0]],
                           dtype=float)


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
    if args.name is None:
        from robocal.kinematics.catalog import catalog_descriptions, catalog_specs

        specs = catalog_specs()
        print(f"{'name':20s} {'reach mm':>8s} {'payload':>9s}  {'class':12s} description")
        for name, text in catalog_descriptions().items():
            reach, payload = specs[name]
            print(f"{name:20s} {_figure(reach, '', 8)} {_figure(payload, ' kg', 9)}  "
                  f"{payload_class(payload):12s} {text}")
        return 0
    show(args.name)
    return 0


PAYLOAD_CLASSES = ((3.0, "light"), (20.0, "small"), (80.0, "medium"), (300.0, "heavy"))


def payload_class(kg: float | None) -> str:
    """The payload class of a vendor payload (kg): light <= 3, small <= 20, medium <= 80, heavy
    <= 300, else very heavy; '-' when unknown."""
    if kg is None:
        return "-"
    return next((label for top, label in PAYLOAD_CLASSES if kg <= top), "very heavy")


def _figure(value, unit: str, width: int) -> str:
    return f"{'-' if value is None else f'{value:g}{unit}':>{width}s}"


def show(spec: str) -> None:
    """Print a robot's parameter table, frames and flange poses."""
    import warnings

    from scipy.spatial.transform import Rotation

    from robocal.kinematics.model import load_model

    robot = load_model(spec)
    print(f"{robot.name}: {robot.description}")
    print("\nmodified DH + beta (T_i = Rx(alpha) Tx(a) Ry(beta) Rz(theta + q) Tz(d))")
    print(f"{'joint':>5} {'alpha deg':>10} {'a mm':>10} {'beta deg':>9} {'theta deg':>10} {'d mm':>10}"
          f"  {'limits deg (mm)':>17}  parallel")
    for i in range(robot.n_joints):
        slide = robot.prismatic[i]  # a prismatic joint: limits in mm, its value adds to d
        lo, hi = robot.limits[i] * 1e3 if slide else np.rad2deg(robot.limits[i])
        print(f"{i + 1:5d} {np.rad2deg(robot.alpha[i]):10.3f} {robot.a[i] * 1e3:10.3f} "
              f"{np.rad2deg(robot.beta[i]):9.3f} {np.rad2deg(robot.theta[i]):10.3f} {robot.d[i] * 1e3:10.3f}"
              f"  {lo:8.1f} {hi:8.1f}  {'yes' if robot.parallel[i] else ''}"
              + ("  prismatic (mm)" if slide else ""))
    for label, T in (("base", robot.base), ("tool", robot.tool)):
        rpy = Rotation.from_matrix(T[:3, :3]).as_euler("xyz", degrees=True)
        print(f"{label}: xyz {np.round(T[:3, 3] * 1e3, 3).tolist()} mm, rpy {np.round(rpy, 3).tolist()} deg")
    q = np.zeros((len(SHOW_JOINTS_DEG), robot.n_joints))
    turning = np.flatnonzero(~robot.prismatic)  # the sample angles go to the revolute joints
    k = min(turning.size, SHOW_JOINTS_DEG.shape[1])
    q[:, turning[:k]] = SHOW_JOINTS_DEG[:, :k]
    T = robot.fk(np.deg2rad(q))  # prismatic joints at 0
    with warnings.catch_warnings():  # gimbal lock at pitch +-90 deg: scipy then sets yaw to 0
        warnings.simplefilter("ignore", UserWarning)
        rpy = Rotation.from_matrix(T[:, :3, :3]).as_euler("xyz", degrees=True)
    print("\ntool pose (x y z mm, fixed-axis roll pitch yaw deg)"
          + ("; prismatic joints at 0" if robot.has_prismatic else ""))
    for j in range(len(q)):
        print(f"q = {np.array2string(q[j], precision=1, separator=', ')} deg  ->  "
              f"xyz {np.array2string(T[j, :3, 3] * 1e3, precision=3, separator=', ')}  "
              f"rpy {np.array2string(rpy[j], precision=3, separator=', ')}")
