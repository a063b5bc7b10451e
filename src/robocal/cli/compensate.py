"""``robocal compensate``: corrected joint commands and Cartesian targets from a calibrated model."""

from __future__ import annotations

import argparse

from robocal.cli.args import numbers, work_cell

EPILOG = """Examples:
  robocal compensate calibrated.yaml targets.csv --nominal abb_irb2600 -o commands.csv
  robocal compensate calibrated.yaml targets.csv --nominal nominal.yaml --branch 0 \\
      --parameters corrected_parameters.csv -o commands.csv
targets.csv: x_mm,y_mm,z_mm (or _m) and qw,qx,qy,qz or rx_deg,ry_deg,rz_deg (fixed-axis XYZ:
R = Rz(rz) Ry(ry) Rx(rx)), by default for the flange (tool0) in the robot's base frame; --tool gives
the real tool, --tool measured the calibrated model's own tool (the measured SMR), --targets-in model
its world frame (after a tracker calibration: the tracker frame).
commands.csv: q1_deg..q6_deg (joints to command), the corrected Cartesian targets (in the
nominal model's base frame and for its TCP: what the controller is given) in the targets'
units, and converged (1/0).
--parameters writes name, unit (mm/deg), nominal, calibrated, delta = nominal - calibrated
(a controller that loads its own parameters takes nominal - delta).
commands.csv starts with a # line naming the calibrated model (fingerprint) and robocal's version;
compensating such a file again is refused unless --force.
A work cell (calibrated_cell.yaml of calibrate --model, --nominal CELL.yaml): targets.csv holds TCP
poses in the positioner's plate frame and the positioner's values (e1_deg, e2_deg: its columns);
commands.csv the arm's joints, the positioner's values as given, the corrected targets in the plate
frame (mm, quaternion: what the nominal controller is given) and converged:
  robocal compensate calibrated_cell.yaml plate_targets.csv --nominal cell.yaml --tool 0,0,200,0,0,0 \
      -o commands.csv"""


def add_parser(sub) -> None:
    p = sub.add_parser("compensate", help="corrected joint commands / Cartesian targets for targets",
                       description="Numeric IK of the targets on the calibrated model, seeded by the "
                                   "nominal closed-form solution; corrected Cartesian targets are the "
                                   "nominal forward kinematics of those joints.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("calibrated",
                   help="calibrated model YAML, or a calibrated work cell (targets on its plate)")
    p.add_argument("targets", help="targets CSV (position + orientation, units in the column names)")
    p.add_argument("--nominal", required=True, help="catalog name or model YAML of the controller's model")
    p.add_argument("--branch", type=int, default=None,
                   help="IK branch slot 0..7 (4*wrist_flip + 2*shoulder + elbow; a SCARA's 0..1, the elbow "
                        "positive or negative); default: per target "
                        "the lowest slot inside the joint limits")
    p.add_argument("--start", type=numbers(None, "q1,...,qn in deg"),
                   help="joints before the first target (deg): each target takes the nominal solution "
                        "nearest the previous target's, as a controller does for targets without "
                        "configuration data (URScript); excludes --branch. An arm without a closed form "
                        "(5 or 7 joints) needs it: each target is solved numerically from the previous one's")
    p.add_argument("--targets-in", choices=("robot", "model"), default="robot",
                   help="frame of the targets: the robot's base frame (default; the calibrated model's "
                        "identified frame {0}) or the calibrated model's world frame (the tracker's)")
    p.add_argument("--tool", metavar="x,y,z,rx,ry,rz", default="flange",
                   help="the TCP the targets are for: flange (default, tool0), x,y,z,rx,ry,rz (the user's "
                        "real tool on the flange, mm, deg, fixed-axis XYZ; e.g. from robocal tool), or "
                        "measured (the calibrated model's own tool: the SMR or probe it was measured with)")
    p.add_argument("--force", action="store_true",
                   help="compensate targets robocal already compensated (their marker line names the run)")
    p.add_argument("--payload", type=numbers(None, "KG or KG,X,Y,Z with X,Y,Z in mm"), metavar="KG[,X,Y,Z]",
                   help="the payload the targets are run with: its mass (kg) and centre of mass in the "
                        "flange frame tool0 (mm; default at the flange), for a model with a payload term")
    p.add_argument("--temperature", type=float, metavar="C",
                   help="the arm's temperature (deg C) the targets are run at, for a model with a "
                        "thermal term")
    p.add_argument("--parameters", help="also write the corrected-parameter table (CSV) here")
    p.add_argument("--arm", metavar="NAME", help="with a cell of several arms: the arm (body name or unit, "
                   "ROB_2) that reaches the targets on the plate")
    p.add_argument("-o", "--output", required=True, help="commands CSV to write")
    p.add_argument("--result", metavar="result.json",
                   help="the calibration's result JSON (calibrate --json): warn per target where its "
                        "predicted error exceeds 3 x the validated one (outside the calibrated region)")
    p.set_defaults(func=run)


# what the targets are, as the options say (printed before the summary)
FRAMES = {"robot": "the robot's base frame (the calibrated frame {0})",
          "model": "the calibrated model's world frame (where it was measured)"}
TOOLS = {"flange": "the flange (tool0)",
         "measured": "the calibrated model's own tool (the measured SMR or probe)"}


def run(args) -> int:
    import numpy as np

    from robocal.cli.args import check_format
    from robocal.core.errors import DataError
    from robocal.core.io import check_outputs
    from robocal.deploy.compensation import compensate, read_targets
    from robocal.deploy.models import load_model_pair, load_prediction, payload_si, tool_frame

    check_format(args.output, "CSV", "-o")
    check_format(args.parameters, "CSV", "--parameters")
    check_outputs([args.output, args.parameters], [args.calibrated, args.targets, args.nominal])
    if (cell := work_cell(args.calibrated, positioner=True)) is not None:  # targets on a positioner's plate
        return _compensate_cell(args, cell)
    if args.arm is not None:
        raise DataError(f"--arm names an arm of a work cell: {args.calibrated} is not one")
    calibrated, nominal = load_model_pair(args.calibrated, args.nominal, "calibrated model")
    origin = calibrated.base[:3, 3] if args.targets_in == "model" else np.zeros(3)
    targets, layout = read_targets(args.targets, nominal, origin, args.force)
    tool = {"measured": None, "flange": np.eye(4)}.get(args.tool)
    if args.tool not in TOOLS:
        tool = tool_frame(args.tool, "--tool")
    prediction = load_prediction(args.result, calibrated, [args.output, args.parameters])
    res = compensate(calibrated, nominal, targets, branch=args.branch,
                     start=None if args.start is None else np.deg2rad(args.start),
                     targets_frame=args.targets_in, tool=tool, e1=layout.get("e1"),
                     payload=payload_si(args.payload), temperature=args.temperature, layout=layout,
                     prediction=prediction)
    res.write(args.output, args.parameters)
    if not args.quiet:
        what = TOOLS.get(args.tool, f"the tool {args.tool} (mm, deg) on the flange")
        print(f"targets: {what} in {FRAMES[args.targets_in]}")
        print(f"{res.summary()} -> {args.output}")
    for warning in res.warnings:
        print(f"warning: {warning}")
    return 0 if res.converged.all() else 1


def _compensate_cell(args, calibrated) -> int:
    """``compensate CELL.yaml TARGETS.csv --nominal CELL.yaml``: targets on the plate, one call."""
    import numpy as np

    import robocal as rc
    from robocal.core.errors import DataError
    from robocal.deploy.cell import read_positioner_values
    from robocal.deploy.compensation import read_poses_csv
    from robocal.deploy.models import tool_frame

    unsupported = [o for o, v in (("--parameters", args.parameters), ("--result", args.result),
                                  ("--targets-in", args.targets_in != "robot"), ("--payload", args.payload),
                                  ("--temperature", args.temperature is not None),
                                  ("--tool measured", args.tool == "measured")) if v]
    if unsupported:
        raise DataError(f"compensate with a work cell takes targets on the plate: not "
                        f"{', '.join(unsupported)}")
    if len(calibrated.positioners) != 1:
        raise DataError("the cell has several positioners: compensate their targets with rc.compensate")
    nominal = rc.load_cell(args.nominal)
    targets, _ = read_poses_csv(args.targets)
    positioner = next(iter(calibrated.positioners.values()))
    e = read_positioner_values(args.targets, positioner)
    tool = None if args.tool == "flange" else tool_frame(args.tool, "--tool")
    res = rc.compensate(calibrated, nominal, targets, positioner_values=e, tool=tool, branch=args.branch,
                        start=None if args.start is None else np.deg2rad(args.start), arm=args.arm)
    arm = calibrated.arms[res.arm]
    res.write(args.output, [j.column for j in arm.joints], [j.column for j in positioner.joints])
    if not args.quiet:
        print(f"{res.summary()} -> {args.output}")
    for warning in res.warnings:
        print(f"warning: {warning}")
    return 0 if res.arm_compensation.converged.all() else 1
