"""``robocal filter``: a robot program with every Cartesian target corrected by the calibrated model."""

from __future__ import annotations

import argparse
from pathlib import Path

from robocal.cli.args import numbers
from robocal.errors import DataError

EPILOG = """Examples:
  robocal filter weld.mod --calibrated cal.yaml --nominal abb_irb2600 -o weld_cal.mod
  robocal filter weld.mod --calibrated cal.yaml --nominal abb_irb2600 --tcp tGun=50.12,0.03,199.71,0,30,0 \\
      -o weld_cal.mod --table weld_targets
  robocal filter pal.src pal.dat --references KRC/R1/System/$config.dat --calibrated cal.yaml \\
      --nominal kuka_kr16_2 -o filtered/
  robocal filter seal.ls --frame 1=450,-150,100,0,0,-10 --tool 2=0,0,120,0,0,0 --calibrated cal.yaml \\
      --nominal fanuc_lrmate200id -o seal_cal.ls
  robocal filter pick.script --tool 0,0.02,0.15,0,0,0.5 --calibrated cal.yaml --nominal ur5 -o pick_cal.script
Formats (from the suffix, or --format): rapid (.mod .modx .prg .sys), krl (.src .dat .sub), fanuc (.ls),
urscript (.script .urscript). --tool / --frame give the controller's tool and frame data the files do
not hold, NAME=values in the program's own notation: ABB x,y,z (mm),q1,q2,q3,q4; KUKA X,Y,Z (mm),A,B,C
(deg); FANUC X,Y,Z (mm),W,P,R (deg); URScript x,y,z (m),rx,ry,rz (rad); names are the tooldata/wobjdata
names, the KUKA TOOL_DATA/BASE_DATA and FANUC UT/UF numbers, URScript feature variables (an unnamed
URScript --tool is the installation's TCP). --tcp NAME=x,y,z,rx,ry,rz (mm, deg, fixed-axis XYZ) is the
real TCP of that tool identified on the calibrated model (robocal tool); default: the tool data.
The calibrated model's identified frame {0} is the controller's base unless --robot-base gives the
controller's base in the calibrated model's world frame (x,y,z,rx,ry,rz, mm, deg).
Writes the filtered program(s) and the per-target table (CSV and JSON) together, or nothing."""


# what each language's files look like, and its motion instructions to a named point
SUFFIXES = {"rapid": (".mod", ".modx", ".prg", ".sys"), "krl": (".src", ".dat", ".sub"),
            "fanuc": (".ls",), "urscript": (".script", ".urscript")}
LANGUAGES = {"rapid": "ABB RAPID", "krl": "KUKA KRL", "fanuc": "FANUC TP (.ls)", "urscript": "URScript"}
SIGNATURES = {"rapid": r"^\s*(?:MODULE\s+\w+|PROC\s+\w+\s*\(|Move[LJC]\s)",
              "krl": r"^\s*(?:DEF\s+\w+\s*\(|DEFDAT\s|(?:PTP|LIN|CIRC)\s+\w)",
              "fanuc": r"^/(?:PROG|MN|POS)\b", "urscript": r"^\s*def\s+\w+\s*\(.*\)\s*:|\bmove[ljpc]\s*\("}
MOTION = {"krl": r"^\s*(?:S?PTP|S?LIN|S?CIRC)\s+([A-Za-z_$][\w$]*)",
          "rapid": r"^\s*Move[LJC]\s+([A-Za-z_]\w*)"}


def _diagnose_empty(args) -> None:
    """No Cartesian target was found: refuse when the files say why (another language than the
    suffix says, or motions to points declared in no file given, e.g. a KRL .src without its .dat)."""
    import re

    texts = {p: Path(p).read_text(encoding="utf-8", errors="replace")
             for p in [*args.programs, *args.references]}
    suffix = Path(args.programs[0]).suffix.lower()
    language = args.format or next((k for k, s in SUFFIXES.items() if suffix in s), None)
    if language is None:
        return
    for path in args.programs:
        text = texts[path]
        if re.search(SIGNATURES[language], text, re.M | re.I):
            continue
        other = [k for k in SIGNATURES if k != language and re.search(SIGNATURES[k], text, re.M | re.I)]
        if other:
            raise DataError(f"{path} looks like {LANGUAGES[other[0]]}, not {LANGUAGES[language]} as its name "
                            f"says: give --format {other[0]} (or name it {SUFFIXES[other[0]][0]})")
    if language not in MOTION:
        return
    names = {m for p in args.programs for m in re.findall(MOTION[language], texts[p], re.M | re.I)}
    every = "\n".join(texts.values())
    undeclared = sorted(n for n in names if not re.search(rf"\b{re.escape(n)}\s*(?::=|=)", every, re.I))
    if undeclared:
        hint = " (a KUKA .src's points are in its .dat: give both files)" if language == "krl" else ""
        files, points = ", ".join(args.programs), ", ".join(undeclared[:8])
        raise DataError(f"{files} move(s) to {points}, declared in none of the files given{hint}; give the "
                        "files that declare them (or --references)")


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
                       description="Every Cartesian target of an ABB RAPID, KUKA KRL, FANUC TP (.ls) or "
                                   "URScript program is replaced by the target the controller's nominal "
                                   "model must be given so that the real robot lands where the program "
                                   "meant; everything else in the file stays byte for byte.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("programs", nargs="+", help="program file(s); a KUKA .src with its .dat")
    p.add_argument("--calibrated", required=True, help="calibrated model YAML")
    p.add_argument("--nominal", required=True, help="catalog name or model YAML of the controller's model")
    p.add_argument("-o", "--output", required=True,
                   help="filtered program (one input) or an existing folder (several inputs)")
    p.add_argument("--tool", action="append", metavar="NAME=VALUES", help="controller tool data (repeatable)")
    p.add_argument("--frame", action="append", metavar="NAME=VALUES",
                   help="work object / base / user frame / feature (repeatable)")
    p.add_argument("--tcp", action="append", metavar="NAME=x,y,z,rx,ry,rz",
                   help="real TCP on the calibrated flange, mm and deg (repeatable)")
    p.add_argument("--robot-base", metavar="x,y,z,rx,ry,rz",
                   help="the controller's base in the calibrated model's world frame (mm, deg)")
    p.add_argument("--references", nargs="+", default=[], metavar="FILE",
                   help="files read for tool/frame declarations only ($config.dat, system modules)")
    p.add_argument("--payload", type=numbers(None, "KG or KG,X,Y,Z with X,Y,Z in mm"), metavar="KG[,X,Y,Z]",
                   help="the payload every target is run with: its mass (kg) and centre of mass in the "
                        "flange frame tool0 (mm; default at the flange), for a model with a payload term")
    p.add_argument("--temperature", type=float, metavar="C",
                   help="the arm's temperature (deg C) the program runs at, for a model with a thermal term")
    p.add_argument("--format", choices=("rapid", "krl", "fanuc", "urscript"), help="program format")
    p.add_argument("--table", help="per-target table: PATH.csv, PATH.json, or a prefix for both "
                                   "(default: OUTPUT.targets.csv/.json)")
    p.add_argument("--keep-unreached", action="store_true",
                   help="leave targets that cannot be corrected unchanged (warning) instead of failing")
    p.set_defaults(func=run)


def _output_paths(programs: list[str], output: str, table: str | None) -> tuple[dict, str, list[Path]]:
    """(program -> output path, the table's path or prefix, every file that will be written)."""
    from robocal.programs.filter import table_paths

    out = Path(output)
    inputs = [Path(p) for p in programs]
    if len(inputs) == 1 and not out.is_dir():
        targets = {inputs[0]: out}
        table = table or str(out) + ".targets"
    else:
        if not out.is_dir():
            raise DataError(f"{out} is not a folder: with several program files, -o names an existing folder")
        targets = {p: out / p.name for p in inputs}
        table = table or str(out / (inputs[0].stem + ".targets"))
    return targets, table, [*targets.values(), *table_paths(table)]


def _check_tool_units(args) -> None:
    """Refuse --tool data whose translation says another unit than the program's notation (mm;
    URScript m)."""
    from robocal.cli.args import check_tool_mm
    from robocal.errors import UnitError

    metres = args.format == "urscript" or (args.format is None and any(
        Path(p).suffix.lower() in (".script", ".urscript") for p in args.programs))
    for name, text in _named(args.tool, "--tool").items():
        try:
            xyz = [float(v) for v in text.replace(" ", "").split(",")[:3]]
        except ValueError:
            continue  # the program reader names malformed values
        if not metres:
            check_tool_mm(xyz, f"--tool {name}={text}")
        elif max(abs(v) for v in xyz) > 5.0:
            raise UnitError(f"--tool {name}={text}: a URScript TCP {max(abs(v) for v in xyz):g} m from the "
                            "flange: URScript lengths are metres (these look like mm)")


def run(args) -> int:
    import sys

    from robocal.cli.args import conditions_unused, payload_si, tool_frame
    from robocal.compensate import frame_from_text
    from robocal.io import check_outputs
    from robocal.kinematics.model import Robot, load_model
    from robocal.programs import filter_program

    targets, table, written = _output_paths(args.programs, args.output, args.table)
    check_outputs(written, [*args.programs, args.calibrated, args.nominal, *args.references])
    calibrated = Robot.load(args.calibrated)
    nominal = load_model(args.nominal)
    tcp = {k: tool_frame(v, f"--tcp {k}=") for k, v in _named(args.tcp, "--tcp").items()}
    _check_tool_units(args)
    base = None if args.robot_base is None else frame_from_text(args.robot_base, "--robot-base")
    res = filter_program(args.programs, calibrated, nominal, tools=_named(args.tool, "--tool"),
                         frames=_named(args.frame, "--frame"), tcp=tcp, robot_base=base,
                         dialect=args.format, references=args.references, keep_unreached=args.keep_unreached,
                         payload=payload_si(args.payload), temperature=args.temperature)
    res.warnings[:0] = conditions_unused(calibrated, args)
    if not res.rows:
        _diagnose_empty(args)
    written = res.write({p: targets[Path(p)] for p in res.outputs}, table)
    if args.quiet:  # the warnings still matter
        for w in res.warnings:
            print(f"robocal filter: warning: {w}", file=sys.stderr)
        return 0
    print(res.summary())
    print("wrote " + ", ".join(str(p) for p in written))
    return 0
