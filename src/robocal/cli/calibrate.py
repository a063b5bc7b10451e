"""``robocal calibrate``: identify the robot's parameters from measurements."""

from __future__ import annotations

import argparse
from pathlib import Path

EPILOG = """Examples:
  robocal calibrate data.csv --robot abb_irb2600 --validate val.csv -o calibrated.yaml --json result.json
  robocal calibrate data.csv --robot nominal.yaml --method robust --set k0=1.5 --set k1=3.0
  robocal calibrate data.csv --robot meca500 --params "a2 a3 d4 theta2 theta3" --report report.html
  robocal calibrate irb120.csv --robot abb_irb120 --hold-out 500 --nongeometric auto
  robocal calibrate irb120.csv --robot abb_irb120 --hold-out 500 --nongeometric compliance,backlash,travel
  robocal calibrate data.csv --robot abb_irb2600 --method genetic --set population=60 --set generations=100
  robocal calibrate data.csv --robot abb_irb2600 --method neural --set hidden=10 --network-out net.npz

Method options (--set KEY=VALUE, SI units): robust: k0, k1, ridge (double-h|gcv|lcurve|none);
genetic: population, generations, crossover, mutation, elite, encoding (binary|real), bits,
spread, threshold (m); swarm: particles, iterations, inertia, c1, c2, vmax, polish (0|1),
threshold (m); neural: hidden, index (mae|mse), learning_rate, epochs, threshold, n_consecutive,
outputs.
"""


RESERVED = ("seed", "method", "params", "validation", "progress", "nongeometric", "register_frames",
            "rtol", "robot", "data", "warm_start")


def _option(text: str):
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    if key in RESERVED:
        raise argparse.ArgumentTypeError(f"{key!r} is not a method option: use the command's own "
                                         f"--{key.replace('_', '-')} argument where there is one")
    for convert in (int, float):
        try:
            return key, convert(value)
        except ValueError:
            pass
    return key, value


def add_parser(sub) -> None:
    p = sub.add_parser("calibrate", help="identify the parameters from measurements",
                       description="Register the tracker frame, select the identifiable parameters, "
                                   "identify them, and report accuracy before and after (mm).",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("data", help="canonical measurement CSV (robocal import / simulate)")
    p.add_argument("--robot", required=True, help="nominal model: catalog name or model YAML")
    p.add_argument("--method", default="lsq", help="lsq (default), robust, genetic, swarm, neural")
    p.add_argument("--params", default="auto",
                   help="auto (identifiable default set), all, or names separated by spaces/commas")
    p.add_argument("--validate", metavar="VAL.csv", help="measurements to judge the result on")
    p.add_argument("--hold-out", type=int, metavar="N",
                   help="judge on the last N poses of DATA (file order) and calibrate on the rest")
    p.add_argument("-o", "--output", metavar="calibrated.yaml", help="write the calibrated model")
    p.add_argument("--json", metavar="result.json", help="write the full result as JSON")
    p.add_argument("--report", metavar="report.html", help="write the HTML report")
    p.add_argument("--seed", type=int, default=0, help="random seed of stochastic methods")
    p.add_argument("--nongeometric", metavar="TERMS", default="default",
                   help="non-geometric terms identified with the geometry (methods lsq, robust): "
                        "compliance, gear, backlash, travel, cyclic (comma separated); auto: the "
                        "terms chosen by cross-validation on the calibration data (the candidate "
                        "table is printed); none: the geometric model only. Default: auto for "
                        "lsq/robust with at least 100 poses of tracker data, else none")
    p.add_argument("--network-out", metavar="net.npz",
                   help="method neural: save the trained network (.npz or .json, plain arrays)")
    p.add_argument("--set", dest="options", type=_option, action="append", default=[],
                   metavar="KEY=VALUE", help="a method option, e.g. k0=1.5, ridge=gcv, population=60")
    p.set_defaults(func=run)


def run(args) -> int:
    import numpy as np

    from robocal.calibration import calibrate
    from robocal.data.measurements import Measurements
    from robocal.errors import DataError, IdentificationError
    from robocal.kinematics.catalog import load_model

    for out in (args.output, args.json, args.report, args.network_out):  # fail before the work
        if out and not Path(out).resolve().parent.is_dir():
            raise DataError(f"cannot write {out}: its folder does not exist")
    robot = load_model(args.robot)
    data = Measurements.load(args.data, robot=robot)
    validation = Measurements.load(args.validate, robot=robot) if args.validate else None
    if args.hold_out:
        if validation is not None:
            raise DataError("give either --validate or --hold-out, not both")
        if not 0 < args.hold_out < data.n_poses:
            raise DataError(f"--hold-out must be between 1 and {data.n_poses - 1} (the data have "
                            f"{data.n_poses} poses)")
        calibration = data.first_poses(data.n_poses - args.hold_out)
        validation = data.subset(~np.isin(data.pose_id, calibration.pose_id))
        data = calibration
    if args.network_out and (args.method != "neural" or not args.network_out.endswith((".npz", ".json"))):
        raise IdentificationError("--network-out needs --method neural and a .npz or .json file name")
    result = calibrate(robot, data, method=args.method, params=args.params, validation=validation,
                       seed=args.seed, progress=not args.quiet, nongeometric=args.nongeometric,
                       **dict(args.options))
    # every output is computed before the first is written: a failure leaves nothing behind
    report = None
    if args.report:
        from robocal.report.html import render_report

        report = render_report(result.to_dict())
    if args.output:
        result.robot.save(args.output)
    if args.json:
        result.save_json(args.json)
    if args.network_out:
        result.solver.extra["network"].save(args.network_out)
    if report is not None:
        from robocal.kinematics.yaml_io import write_atomic

        write_atomic(args.report, report)
    print(result.summary())
    for path in (args.output, args.json, args.report, args.network_out):
        if path:
            print(f"wrote {path}")
    return 0
