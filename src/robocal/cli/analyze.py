"""``robocal analyze``: identifiability and observability of a pose set, before measuring."""

from __future__ import annotations

import argparse

from robocal.cli.args import numbers

EPILOG = """Examples:
  robocal analyze planned_poses.csv --robot abb_irb2600 --tool-mm 30,20,80   # joints only is enough
  robocal analyze data.csv --robot meca500 --kind pose
"""


def add_parser(sub) -> None:
    p = sub.add_parser("analyze", help="identifiability and observability of a pose set",
                       description="Which parameters a set of poses determines, in the words the "
                                   "calibration will use: estimated, not determined by these data (held "
                                   "near nominal by their priors) or not identifiable (exactly confounded "
                                   "or without effect); the condition number of the normal matrix and the "
                                   "observability indices O1-O4.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("data", help="CSV with joint columns q1_deg.. (or _rad); with measured points (x_mm.. "
                                "or x_m..), the tracker frame and SMR offsets are fitted to them first, as "
                                "calibrate does (unless --tool-mm is given)")
    p.add_argument("--robot", required=True, help="nominal model: catalog name or model YAML")
    p.add_argument("--kind", choices=("point", "pose"), default="point",
                   help="what will be measured at each pose (default: point)")
    p.add_argument("--params", default="auto", help="auto, all, or names")
    p.add_argument("--noise-mm", type=float, default=0.02,
                   help="measurement noise, 1 sigma per coordinate in mm (default 0.02): how much the data "
                        "weigh against the parameters' priors")
    p.add_argument("--tool-mm", metavar="X,Y,Z", type=numbers(3, "X,Y,Z in mm"),
                   help="the SMR/tool position on the flange in mm (default: the model's tool); "
                        "an SMR on the flange axis leaves the last joint's offset unobservable")
    p.set_defaults(func=run)


def run(args) -> int:
    import numpy as np

    from robocal.calibration.pipeline import analyze
    from robocal.core.io import LENGTH_UNITS
    from robocal.data.measurements import Measurements, read_joint_table
    from robocal.data.registration import register
    from robocal.identify import vocabulary
    from robocal.kinematics.model import load_model

    robot = load_model(args.robot)
    if args.tool_mm:
        tool = robot.tool.copy()
        tool[:3, 3] = np.array(args.tool_mm) * LENGTH_UNITS["mm"]
        robot = robot.with_frames(tool=tool)
    table = read_joint_table(args.data)
    measured = {"x_mm", "x_m"} & set(table.header) and not args.tool_mm
    # a measurement file: the tracker frame and the SMR offsets fitted to it first, each pose with the
    # SMRs it measured: the parameters are judged on the model calibrate starts from
    data = Measurements.load(args.data) if measured else table.joints_of(robot, args.data)
    if measured:
        robot = register(robot, data)
    ident = analyze(robot, data, kind=args.kind, params=args.params, noise_mm=args.noise_mm)
    n_poses = data.n_poses if isinstance(data, Measurements) else len(data)
    print(f"{n_poses} poses of {robot.name}, {args.kind} measurements (noise {args.noise_mm:g} mm)")
    print(vocabulary.counts(ident))
    print(ident.summary())
    return 0
