"""``robocal filter``: a robot program with every Cartesian target corrected by the calibrated model."""

from __future__ import annotations

import argparse
from pathlib import Path

from robocal.cli.args import numbers
from robocal.core.errors import DataError
from robocal.programs.language_help import FILTER_DESCRIPTION, FILTER_EPILOG, FILTER_OPTIONS
from robocal.programs.registry import DIALECTS


def _named(values, what: str) -> dict[str, str]:
    out = {}
    for v in values or []:
        name, sep, text = v.partition("=")
        if not sep:
            name, text = "default", v
        if not name.strip() or not text.strip():
            raise DataError(f"{what} {v!r}: expected NAME=values")
        out[name.strip()] = text
    return out


def add_parser(sub) -> None:
    p = sub.add_parser("filter", help="correct a robot program's Cartesian targets with the calibrated model",
                       description=FILTER_DESCRIPTION,
                       epilog=FILTER_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("programs", nargs="+",
                   help=FILTER_OPTIONS["programs"])
    p.add_argument("--calibrated", required=True,
                   help="calibrated model YAML (a cell: the calibrated cell file its calibration wrote)")
    p.add_argument("--nominal", "--model", dest="nominal", required=True,
                   help="catalog name or model YAML of the controller's model; a cell file (arm and "
                        "positioner) to correct the targets on the positioner's plate (coordinated motion)")
    p.add_argument("-o", "--output", required=True,
                   help="filtered program (one input) or an existing folder (several inputs)")
    p.add_argument("--arm", metavar="NAME", help="with a cell of several arms: the arm (body name or unit, "
                                                 "ROB_2) whose program this is")
    p.add_argument("--tool", action="append", metavar="NAME=VALUES", help="controller tool data (repeatable)")
    p.add_argument("--frame", action="append", metavar="NAME=VALUES",
                   help="work object / base / user frame / feature (repeatable)")
    p.add_argument("--tcp", action="append", metavar="NAME=x,y,z,rx,ry,rz",
                   help="real TCP on the calibrated flange, mm and deg (repeatable)")
    p.add_argument("--robot-base", metavar="x,y,z,rx,ry,rz",
                   help="the controller's base in the calibrated model's world frame (mm, deg)")
    p.add_argument("--references", nargs="+", default=[], metavar="FILE",
                   help=FILTER_OPTIONS["references"])
    p.add_argument("--payload", type=numbers(None, "KG or KG,X,Y,Z with X,Y,Z in mm"), metavar="KG[,X,Y,Z]",
                   help="the payload every target is run with: its mass (kg) and centre of mass in the "
                        "flange frame tool0 (mm; default at the flange), for a model with a payload term "
                        "(default: each motion with the load the program sets before it)")
    p.add_argument("--payload-schedules", metavar="FILE",
                   help=FILTER_OPTIONS["payload_schedules"])
    p.add_argument("--temperature", type=float, metavar="C",
                   help="the arm's temperature (deg C) the program runs at, for a model with a thermal term")
    p.add_argument("--format", choices=tuple(DIALECTS), help="program format")
    p.add_argument("--table", help="per-target table: PATH.csv, PATH.json, or a prefix for both "
                                   "(default: OUTPUT.targets.csv/.json)")
    p.add_argument("--force", action="store_true",
                   help="filter a program robocal already filtered (its marker comment names the run): "
                        "the corrections are applied again")
    p.add_argument("--result", metavar="result.json",
                   help="the calibration's result JSON (calibrate --json): warn where targets lie whose "
                        "predicted error exceeds 3 x the validated one (outside the calibrated region)")
    p.add_argument("--fixed-base", action="store_true",
                   help="no external axis carries the arm (no track or gantry): targets with external-axis "
                        "values in work objects no unit moves are corrected as arm targets (default: the "
                        "targets of an axis that carries the arm, a track the targets follow, or may, are "
                        "named)")
    p.add_argument("--keep-unreached", action="store_true",
                   help="leave targets that cannot be corrected unchanged (warning) instead of failing")
    p.add_argument("--position-registers", metavar="FILE.csv",
                   help=FILTER_OPTIONS["position_registers"])
    p.add_argument("--strict", action="store_true",
                   help="refuse when a motion moves to a name declared in none of the files given (default: "
                        "each such motion is named, with the declaration it needs, and the rest corrected)")
    p.add_argument("--runtime-correction", action="store_true",
                   help="add a routine in the program's language that corrects targets computed at run time "
                        "(run-time offsets, positions modified at run time) with the calibrated model, and "
                        "route those motions through it (docs/programs.md)")
    p.set_defaults(func=run)


def _output_paths(programs: list[str], output: str, table: str | None,
                  registers: str | None = None) -> tuple[dict, str, list[Path]]:
    """(program -> output path, the table's path or prefix, every file that will be written); a
    folder (an application) stands for its files; the corrected copy of a position register
    file goes to ``OUTPUT.registers.csv`` (one program) or into the output folder under its own
    name."""
    from robocal.programs.registry import program_files
    from robocal.programs.result import table_paths

    out = Path(output)
    inputs = program_files([Path(p) for p in programs])
    if len(inputs) == 1 and not out.is_dir():
        targets = {inputs[0]: out}
        table = table or str(out) + ".targets"
    else:
        if not out.is_dir():
            raise DataError(f"{out} is not a folder: with several program files, -o names an existing folder")
        targets = {p: out / p.name for p in inputs}
        table = table or str(out / (inputs[0].stem + ".targets"))
    if registers is not None:
        reg = Path(registers)
        targets[reg] = Path(str(out) + ".registers.csv") if len(inputs) == 1 and not out.is_dir() \
            else out / reg.name
    return targets, table, [*targets.values(), *table_paths(table)]


def run(args) -> int:
    import sys

    from robocal.core.io import check_outputs
    from robocal.deploy.models import load_models, load_prediction, payload_si, tool_frame
    from robocal.programs import filter_program

    targets, table, written = _output_paths(args.programs, args.output, args.table, args.position_registers)
    check_outputs(written, [*targets, args.calibrated, args.nominal, *args.references,
                            *([args.position_registers] if args.position_registers else []),
                            *([args.payload_schedules] if args.payload_schedules else [])])
    calibrated, nominal = load_models(args.calibrated, args.nominal)
    prediction = load_prediction(args.result, calibrated, written)
    tcp = {k: tool_frame(v, f"--tcp {k}=") for k, v in _named(args.tcp, "--tcp").items()}
    res = filter_program(args.programs, calibrated, nominal, tools=_named(args.tool, "--tool"),
                         frames=_named(args.frame, "--frame"), tcp=tcp, robot_base=args.robot_base,
                         dialect=args.format, references=args.references, keep_unreached=args.keep_unreached,
                         force=args.force, strict=args.strict, position_registers=args.position_registers,
                         payload=payload_si(args.payload), temperature=args.temperature,
                         payload_schedules=args.payload_schedules, prediction=prediction, arm=args.arm,
                         fixed_base=args.fixed_base, runtime_correction=args.runtime_correction)
    written = res.write({p: targets[Path(p)] for p in res.outputs if p not in res.derived}, table)
    if args.quiet:  # the warnings still matter
        for w in res.warnings:
            print(f"robocal filter: warning: {w}", file=sys.stderr)
        return 0
    print(res.summary())
    print("wrote " + ", ".join(str(p) for p in written))
    return 0
