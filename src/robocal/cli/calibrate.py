"""``robocal calibrate``: identify the robot's parameters from measurements."""

from __future__ import annotations

import argparse

from robocal.cli.args import INSTRUMENT_NAMES, add_fanuc_coupled, add_model_options
from robocal.cli.history_options import add_history_options
from robocal.core.io import LENGTH_UNITS

EPILOG = """Examples:
  robocal calibrate data.csv --robot abb_irb2600 --validate val.csv -o calibrated.yaml --json result.json
  robocal calibrate data.csv --robot nominal.yaml --method robust --set k0=1.5 --set k1=3.0
  robocal calibrate data.csv --robot meca500 --params "a2 a3 d4 theta2 theta3" --report report.html
  robocal calibrate irb120.csv --robot abb_irb120 --hold-out 500 --nongeometric auto
  robocal calibrate irb120.csv --robot abb_irb120 --hold-out 500 --nongeometric compliance,backlash,travel
  robocal calibrate data.csv --robot abb_irb2600 --method genetic --set population=60 --set generations=100
  robocal calibrate data.csv --robot abb_irb2600 --method neural --set hidden=10 --network-out net.npz
  robocal calibrate contacts.csv scalebar.csv --robot abb_irb2600 --sigma plane=0.01 --sigma distance=0.005
  robocal calibrate check.csv --robot abb_irb2600 --offsets-only --start calibrated.yaml -o recalibrated.yaml
  robocal calibrate board.csv --robot ur10 --instrument camera --validate held.csv   # a camera's board poses
  robocal calibrate mocap.csv --robot tiago.yaml --priors class=service,zeros=3deg,lengths=10mm
  robocal calibrate cell.csv --model cell.yaml --validate held.csv -o calibrated_cell.yaml --json cell.json
      # a work cell (arm + positioner): one calibration per body in one tracker frame; the CSV's body
      # column names each row's body, e1_deg.. hold the positioner's axes

Method options (--set KEY=VALUE, SI units): lsq: max_iter (50); robust: k0, k1, ridge
(double-h|gcv|lcurve|none), max_outer (30); genetic: population, generations (100), crossover,
mutation, elite, encoding (binary|real), bits, spread, threshold (m), patience (20), ftol; swarm:
particles, iterations (300), inertia, c1, c2, vmax, polish (0|1), polish_iter, threshold (m),
patience (50), ftol; neural: hidden, index (mae|mse), learning_rate, epochs, threshold,
n_consecutive, outputs.
Stopping: lsq stops when converged (the linear model promises less than 1e-10 of the cost) or at
max_iter; robust when the IGG3 weights or the fit settle, or at max_outer; genetic and swarm when
the best error improved by less than ftol (relative) over the last patience generations
(iterations), when it reaches threshold, or at the limit (not a success). Every estimate carries
the parameter priors (docs/priors.md); parameters the data do not determine are held at nominal.
"""


RESERVED = ("seed", "method", "params", "validation", "progress", "nongeometric", "register_frames",
            "rtol", "robot", "data", "force", "warm_start", "sigma", "priors", "instrument",
            "variance_components")


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


def _sigma(text: str) -> tuple[str, float]:
    """``KIND=MM`` -> (kind, m): an argparse type (calibrate checks the kind and the value)."""
    kind, sep, value = text.partition("=")
    try:
        mm = float(value)
    except ValueError:
        mm = None
    if not sep or not kind.strip() or mm is None:
        raise argparse.ArgumentTypeError(f"expected KIND=MM, e.g. plane=0.01, got {text!r}")
    return kind.strip(), mm * LENGTH_UNITS["mm"]


def _priors(text: str):
    """``--priors`` text -> PriorSpec (robocal.kinematics.prior_spec): an argparse type."""
    from robocal.core.errors import ModelError
    from robocal.kinematics.prior_spec import PriorSpec

    try:
        return PriorSpec.parse(text)
    except ModelError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_parser(sub) -> None:
    p = sub.add_parser("calibrate", help="identify the parameters from measurements",
                       description="Register the tracker frame, select the identifiable parameters, "
                                   "identify them, and report accuracy before and after (mm).",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("data", nargs="+", help="canonical measurement CSV(s) (robocal import / simulate); "
                                           "several files of any kinds are identified together")
    add_model_options(p, "nominal model: catalog name or model YAML",
                      "a work cell file (arms, positioners): each body calibrated on its rows (the "
                      "data's body column) in one tracker frame; writes the calibrated cell (-o) and "
                      "the result (--json) and each body's report (--report R.html: R_<body>.html); "
                      "--hold-out N holds out the last N poses of each body")
    p.add_argument("--method", help="lsq, robust, genetic, swarm, neural (default: robust for data of an "
                                    "instrument with heavy-tailed errors, mocap or camera; else lsq)")
    p.add_argument("--instrument", choices=INSTRUMENT_NAMES,
                   help="the instrument that took the files declaring none (a '# instrument: NAME' line "
                        "declares it in a file): its documented noise weighs them, a mocap's or camera's "
                        "heavy-tailed errors make robust the default method and a camera's 6-D poses get "
                        "their position and rotation noise estimated (variance components)")
    p.add_argument("--variance-components", action=argparse.BooleanOptionalAction, default=None,
                   help="estimate the position and rotation noise of 6-D pose files from the fit (iterated "
                        "variance components) and weigh them with it; default: for a camera's files and "
                        "6-D files of a declared instrument other than a laser tracker. Use it for a "
                        "6-DOF sensor whose noise ratio is not documented")
    p.add_argument("--params", default="auto",
                   help="auto (identifiable default set), all, or names separated by spaces/commas")
    p.add_argument("--validate", metavar="VAL.csv", nargs="+",
                   help="measurements to judge the result on (several files: each judged in its unit)")
    p.add_argument("--sigma", action="append", default=[], metavar="KIND=MM", type=_sigma,
                   help="1-sigma noise of a kind's files without a sigma_mm column, e.g. plane=0.01, "
                        "distance=0.005 (defaults: point 0.02, pose 0.02, plane 0.01, distance 0.005)")
    p.add_argument("--hold-out", type=int, metavar="N",
                   help="judge on the last N poses of DATA (file order) and calibrate on the rest")
    p.add_argument("-o", "--output", metavar="calibrated.yaml", help="write the calibrated model")
    p.add_argument("--json", metavar="result.json", help="write the full result as JSON")
    p.add_argument("--report", metavar="report.html", help="write the HTML report")
    p.add_argument("--seed", type=int, default=0, help="random seed of stochastic methods")
    p.add_argument("--nongeometric", metavar="TERMS", default="default",
                   help="non-geometric terms identified with the geometry (methods lsq, robust): "
                        "compliance, gear, backlash, travel, cyclic, payload, thermal, thermal_groups (comma "
                        "separated; payload and thermal need the payload_kg and temperature_c columns; "
                        "thermal_groups: a k per link group beside the shared one); auto: the "
                        "terms chosen by cross-validation on the calibration data (the candidate "
                        "table is printed); none: the geometric model only. Default: auto for "
                        "lsq/robust on one file of tracker data (points or poses) with at least 100 "
                        "poses, else none")
    p.add_argument("--priors", type=_priors, metavar="GROUP=SCALE,...",
                   help="the parameter priors (docs/priors.md): class=industrial|collaborative|service|"
                        "positioner (service: humanoids, mobile manipulators, low-cost arms; positioner: "
                        "tables and turntables; default: chosen from the model), group scales with their "
                        "unit: zeros=3deg, twists=1deg, lengths=10mm, "
                        "errors=2x (a factor on the joint-error terms' scales), estimate=no (keep the "
                        "class defaults instead of widening them where the data ask for it); on top of "
                        "the model file's priors: block")
    p.add_argument("--network-out", metavar="net.npz",
                   help="method neural: save the trained network (.npz or .json, plain arrays)")
    p.add_argument("--set", dest="options", type=_option, action="append", default=[],
                   metavar="KEY=VALUE", help="a method option, e.g. k0=1.5, ridge=gcv, population=60")
    p.add_argument("--force", action="store_true",
                   help="proceed past the plausibility checks (units, robot, corrections) and write the "
                        "results of a solve that did not converge, with loud warnings")
    p.add_argument("--offsets-only", action="store_true",
                   help="re-identify only the joint zeros (with the tracker frame and SMR offsets) of the "
                        "calibrated model --start, every other parameter kept: after a motor or encoder "
                        "change, from a short campaign")
    p.add_argument("--start", metavar="CALIBRATED.yaml",
                   help="with --offsets-only: the earlier calibrated model of this robot (--robot names "
                        "the nominal one)")
    add_history_options(p)
    add_fanuc_coupled(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.calibration.pipeline import calibrate
    from robocal.calibration.result import check_network_output
    from robocal.cli.args import check_format, load_measurements
    from robocal.core.io import check_outputs
    from robocal.data.inputs import check_distinct_inputs
    from robocal.history.offsets import offsets_start, recalibrate_offsets, shifts_line, zero_shifts
    from robocal.history.record import calibration_record, open_history, parent_calibration, record_entry
    from robocal.kinematics.model import load_model

    validate = args.validate or []
    check_outputs((args.output, args.json, args.report, args.network_out),
                  (*args.data, *validate, args.robot, args.model, args.start))  # fail before the work
    check_format(args.output, "YAML", "-o", " (or use --json for the result)")
    check_format(args.json, "JSON", "--json")
    check_format(args.report, "HTML", "--report")
    check_distinct_inputs(args.data, "calibration files")
    check_distinct_inputs([*args.data, *validate], "calibration and validation files",
                          "a validation on the calibration data says nothing of the accuracy elsewhere")
    check_network_output(args.network_out, args.method)  # fail before the work
    if args.model:  # a work cell: one calibration per body (robocal.calibration.cell)
        return _calibrate_cell(args, validate)
    robot_id = open_history(args.history, args.robot_id,
                            outputs=[args.output, args.json, args.report, args.network_out])
    start = offsets_start(args.start, args.offsets_only, args.params, args.nongeometric)
    robot = load_model(args.robot)
    def read(files: list[str]) -> list:  # conditions without a term in the model: result.notes
        return [load_measurements(f, robot, args.quiet, args.fanuc_coupled, model_used=False) for f in files]

    data, validation = read(args.data), read(validate)
    common = dict(validation=validation or None, method=args.method, seed=args.seed, progress=not args.quiet,
                  force=args.force, sigma=dict(args.sigma), hold_out=args.hold_out,
                  instrument=args.instrument, **dict(args.options))
    if start is None:
        result = calibrate(robot, data, params=args.params, nongeometric=args.nongeometric,
                           priors=args.priors, variance_components=args.variance_components, **common)
    else:
        result = recalibrate_offsets(robot, start, data, history=args.history, robot_id=robot_id, **common)
    result.provenance.update(command="robocal " + " ".join(args.argv), robot_spec=args.robot,
                             data_file=", ".join(args.data), validation_file=", ".join(validate) or None,
                             hold_out=result.provenance.pop("hold_out", None))  # the calibration's, last
    print(result.summary())
    derived = {} if start is None else {"offsets_only": True, "zero_shifts": zero_shifts(result, start)}
    if start is not None:
        print(shifts_line(derived["zero_shifts"]))
    for path in result.write(args.output, args.json, args.report, args.network_out, args.force):
        print(f"wrote {path}")
    if args.history:  # after the files: the history is never the only copy
        files = [(f, "calibration") for f in args.data] + [(f, "validation") for f in validate]
        parent = None if start is None else parent_calibration(args.history, robot_id, start)
        said = record_entry(args.history, calibration_record(result, robot_id, files, parent, **derived))
        if not args.quiet:
            print(said)
    return 0


def _calibrate_cell(args, validate: list[str]) -> int:
    """``calibrate --model CELL.yaml``: the cell's data and held-out file, one call, its summary and files."""
    import robocal as rc
    from robocal.core.errors import DataError

    unsupported = [o for o, v in (("--offsets-only", args.offsets_only),
                                  ("--network-out", args.network_out), ("--history", args.history)) if v]
    if unsupported or len(args.data) > 1 or len(validate) > 1:
        raise DataError(f"calibrate --model (a work cell) takes one data file and at most one --validate file"
                        f"{', not ' + ', '.join(unsupported) if unsupported else ''}")
    cell = rc.load_cell(args.model)
    data = rc.CellMeasurements.load(args.data[0], cell)
    validation = rc.CellMeasurements.load(validate[0], cell) if validate else None
    result = rc.calibrate(cell, data, validation=validation, method=args.method, params=args.params,
                          seed=args.seed, progress=not args.quiet, force=args.force, sigma=dict(args.sigma),
                          instrument=args.instrument, nongeometric=args.nongeometric, priors=args.priors,
                          hold_out=args.hold_out, **dict(args.options))
    result.provenance.update(command="robocal " + " ".join(args.argv), model=args.model)
    print(result.summary())
    for path in result.write(args.output, args.json, args.report, args.force):
        print(f"wrote {path}")
    return 0
