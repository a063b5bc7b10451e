"""``robocal filter``: a robot program with every Cartesian target corrected by the calibrated model."""

from __future__ import annotations

import argparse
from pathlib import Path

from robocal.cli.args import numbers
from robocal.core.errors import DataError

EPILOG = """Examples:
  robocal filter weld.mod --calibrated cal.yaml --nominal abb_irb2600 -o weld_cal.mod
  robocal filter weld.mod --calibrated cal.yaml --nominal abb_irb2600 --tcp tGun=50.12,0.03,199.71,0,30,0 \\
      -o weld_cal.mod --table weld_targets
  robocal filter pal.src pal.dat --references KRC/R1/System/$config.dat --calibrated cal.yaml \\
      --nominal kuka_kr16_2 -o filtered/
  robocal filter seal.ls --frame 1=450,-150,100,0,0,-10 --tool 2=0,0,120,0,0,0 --calibrated cal.yaml \\
      --nominal fanuc_lrmate200id -o seal_cal.ls
  robocal filter pick.script --tool 0,0.02,0.15,0,0,0.5 --calibrated cal.yaml --nominal ur5 -o pick_cal.script
  robocal filter WELD.JBI VAR.DAT --frame 2=1250,-300,450,0,0,15 --tool 1=0,-35,410,0,-30,0 \\
      --calibrated cal.yaml --nominal yaskawa_gp25 -o filtered/
Formats (from the suffix, or --format): rapid (.mod .modx .prg .sys), krl (.src .dat .sub), fanuc (.ls),
urscript (.script .urscript), inform (.JBI, and the controller's VAR.DAT), val3 (an application's
folder, or its .pgx and .dtx files). --tool / --frame give the controller's tool and frame data the
files do not hold, NAME=values in the program's own notation: ABB x,y,z (mm),q1,q2,q3,q4; KUKA X,Y,Z
(mm),A,B,C (deg); FANUC X,Y,Z (mm),W,P,R (deg); Yaskawa X,Y,Z (mm),Rx,Ry,Rz (deg); VAL3 x,y,z (mm),
rx,ry,rz (deg); URScript x,y,z (m),rx,ry,rz (rad); names are the tooldata/wobjdata names, the KUKA
TOOL_DATA/BASE_DATA, FANUC UT/UF and Yaskawa TOOL/USER numbers, VAL3 data (fPart[0], tGripper[0]),
URScript feature variables (an unnamed URScript --tool is the installation's TCP). --tcp
NAME=x,y,z,rx,ry,rz (mm, deg, fixed-axis XYZ) is the real TCP of that tool identified on the
calibrated model (robocal tool); default: the tool data.
The calibrated model's identified frame {0} is the controller's base unless --robot-base gives the
controller's base in the calibrated model's world frame (x,y,z,rx,ry,rz, mm, deg).
Writes the filtered program(s) and the per-target table (CSV and JSON) together, or nothing. A filtered
program carries one comment line naming the calibrated model (fingerprint) and robocal's version;
filtering it again is refused unless --force."""


# what each language's files look like
SUFFIXES = {"rapid": (".mod", ".modx", ".prg", ".sys"), "krl": (".src", ".dat", ".sub"),
            "fanuc": (".ls",), "urscript": (".script", ".urscript"), "inform": (".jbi",),
            "val3": (".pgx", ".dtx", ".pjx")}
LANGUAGES = {"rapid": "ABB RAPID", "krl": "KUKA KRL", "fanuc": "FANUC TP (.ls)", "urscript": "URScript",
             "inform": "Yaskawa INFORM (.JBI)", "val3": "Staubli VAL3"}
SIGNATURES = {"rapid": r"^\s*(?:MODULE\s+\w+|PROC\s+\w+\s*\(|Move[LJC]\s)",
              "krl": r"^\s*(?:DEF\s+\w+\s*\(|DEFDAT\s|(?:PTP|LIN|CIRC)\s+\w)",
              "fanuc": r"^/(?:PROG|MN|POS)\b", "urscript": r"^\s*def\s+\w+\s*\(.*\)\s*:|\bmove[ljpc]\s*\(",
              "inform": r"^/JOB\b|^//(?:NAME|POS|INST)\b", "val3": r"staubli\.com/robotics/VAL3"}


def _diagnose_empty(args) -> None:
    """No Cartesian target was found: refuse when the files are in another language than their
    suffix says (motions to points declared in no file given are named, or refused with --strict)."""
    import re

    texts = {p: Path(p).read_text(encoding="utf-8", errors="replace")
             for p in [*args.programs, *args.references] if not Path(p).is_dir()}  # a VAL3 folder: its files
    suffix = Path(args.programs[0]).suffix.lower()
    language = args.format or next((k for k, s in SUFFIXES.items() if suffix in s), None)
    if language is None:
        return
    for path in (p for p in args.programs if p in texts):
        text = texts[path]
        if re.search(SIGNATURES[language], text, re.M | re.I):
            continue
        other = [k for k in SIGNATURES if k != language and re.search(SIGNATURES[k], text, re.M | re.I)]
        if other:
            raise DataError(f"{path} looks like {LANGUAGES[other[0]]}, not {LANGUAGES[language]} as its name "
                            f"says: give --format {other[0]} (or name it {SUFFIXES[other[0]][0]})")


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
                       description="Every Cartesian target of an ABB RAPID, KUKA KRL, FANUC TP (.ls), "
                                   "URScript, Yaskawa INFORM or Staubli VAL3 program is replaced by the "
                                   "target the controller's nominal model must be given so that the real "
                                   "robot lands where the program meant; all else in the file stays byte "
                                   "for byte.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("programs", nargs="+",
                   help="program file(s); a KUKA .src with its .dat; a VAL3 application's folder")
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
                   help="files read for tool/frame/load declarations only ($config.dat, system modules, "
                        "a Yaskawa TOOL.CND / UFRAME.CND)")
    p.add_argument("--payload", type=numbers(None, "KG or KG,X,Y,Z with X,Y,Z in mm"), metavar="KG[,X,Y,Z]",
                   help="the payload every target is run with: its mass (kg) and centre of mass in the "
                        "flange frame tool0 (mm; default at the flange), for a model with a payload term "
                        "(default: each motion with the load the program sets before it)")
    p.add_argument("--payload-schedules", metavar="FILE",
                   help="FANUC: the payload schedules PAYLOAD[n] selects, the controller's SYSVARS.VA "
                        "($PLST_GRP1) or a CSV schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm")
    p.add_argument("--temperature", type=float, metavar="C",
                   help="the arm's temperature (deg C) the program runs at, for a model with a thermal term")
    p.add_argument("--format", choices=("rapid", "krl", "fanuc", "urscript", "inform", "val3"),
                   help="program format")
    p.add_argument("--table", help="per-target table: PATH.csv, PATH.json, or a prefix for both "
                                   "(default: OUTPUT.targets.csv/.json)")
    p.add_argument("--force", action="store_true",
                   help="filter a program robocal already filtered (its marker comment names the run): "
                        "the corrections are applied again")
    p.add_argument("--result", metavar="result.json",
                   help="the calibration's result JSON (calibrate --json): warn where targets lie whose "
                        "predicted error exceeds 3 x the validated one (outside the calibrated region)")
    p.add_argument("--keep-unreached", action="store_true",
                   help="leave targets that cannot be corrected unchanged (warning) instead of failing")
    p.add_argument("--position-registers", metavar="FILE.csv",
                   help="FANUC: the position registers' values (register,x_mm,y_mm,z_mm,w_deg,p_deg,r_deg,"
                        "config): motions to PR[n] are corrected and the corrected registers written to "
                        "OUTPUT.registers.csv")
    p.add_argument("--strict", action="store_true",
                   help="refuse when a motion moves to a name declared in none of the files given (default: "
                        "each such motion is named, with the declaration it needs, and the rest corrected)")
    p.set_defaults(func=run)


def _output_paths(programs: list[str], output: str, table: str | None,
                  registers: str | None = None) -> tuple[dict, str, list[Path]]:
    """(program -> output path, the table's path or prefix, every file that will be written); a
    folder (a VAL3 application) stands for its files; the corrected copy of a position register
    file goes to ``OUTPUT.registers.csv`` (one program) or into the output folder under its own
    name."""
    from robocal.programs.result import table_paths
    from robocal.programs.val3 import application_files

    out = Path(output)
    inputs = [f for p in map(Path, programs) for f in (application_files(p) if p.is_dir() else [p])]
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


def _check_magnitudes(args, reach_m: float) -> None:
    """Refuse --tool / --frame values whose magnitudes say another unit than the program's notation
    (lengths mm, URScript m; KRL and FANUC angles deg, URScript rad) for a robot of ``reach_m``
    (:mod:`robocal.core.magnitudes`)."""
    import numpy as np

    from robocal.core.magnitudes import LENGTH_SCALES_M, check_degrees, check_frame, check_radians, check_tool

    suffix = Path(args.programs[0]).suffix.lower()
    language = args.format or next((k for k, s in SUFFIXES.items() if suffix in s), None)
    unit = "m" if language == "urscript" else "mm"
    for option, given in (("--tool", args.tool), ("--frame", args.frame)):
        for name, text in _named(given, option).items():
            try:
                values = [float(v) for v in text.replace(" ", "").split(",")]
            except ValueError:
                continue  # the program reader names malformed values
            what = f"{option} {name}={text}"
            xyz = np.asarray(values[:3]) * LENGTH_SCALES_M[unit]
            if option == "--tool":
                check_tool(xyz, unit, what)
            else:
                check_frame(xyz, unit, reach_m, what)
            if language in ("krl", "fanuc"):
                check_degrees(values[3:6], what)
            elif language == "urscript":
                check_radians(values[3:6], what)


# a --tool this far from the program's own tool data of the same name is another tool: a warning
TOOL_DISAGREE_MM = 0.5
TOOL_DISAGREE_DEG = 0.1


def _tool_disagreements(args) -> list[str]:
    """One warning per --tool that overrides tool data the program files declare differently
    (naming both); none when the files cannot be read without the overrides."""
    import numpy as np

    from robocal.core.errors import RobocalError
    from robocal.kinematics.transforms import pose_error
    from robocal.programs.filter import as_frames, dialect_for
    from robocal.programs.source import ProgramText

    given = _named(args.tool, "--tool")
    if not given:
        return []
    try:
        d = dialect_for([Path(p) for p in args.programs], args.format)
        frames = as_frames(d, _named(args.frame, "--frame"))
        program = d.parse([ProgramText(p) for p in args.programs], frames, {},
                          [ProgramText(p) for p in args.references])
        tools = {d.name_key(k): v for k, v in as_frames(d, given).items()}
    except RobocalError:
        return []
    out = []
    for key, T in tools.items():
        own = program.tools.get(key)
        if own is None:
            continue
        err = pose_error(np.asarray(own)[None], np.asarray(T)[None])[0]
        mm, deg = np.linalg.norm(err[:3]) * 1e3, np.rad2deg(np.linalg.norm(err[3:]))
        if mm > TOOL_DISAGREE_MM or deg > TOOL_DISAGREE_DEG:
            name = next(k for k in given if d.name_key(k) == key)
            own_text = ", ".join(f"{v:.4g}" for v in np.r_[own[:3, 3] * 1e3])
            out.append(f"--tool {name}={given[name]} replaces the program's own tool data {name} (TCP at "
                       f"{own_text} mm on the flange) and differs from it by {mm:.3g} mm, {deg:.3g} deg: the "
                       "controller moves with the tool data it holds; make sure --tool is what it holds")
    return out


def run(args) -> int:
    import sys

    from robocal.core.io import check_outputs
    from robocal.core.magnitudes import check_degrees, check_frame
    from robocal.data.measurements import robot_reach
    from robocal.deploy.compensation import frame_from_text, unused_conditions
    from robocal.deploy.models import load_model_pair, load_prediction, payload_si, tool_frame
    from robocal.programs import filter_program

    targets, table, written = _output_paths(args.programs, args.output, args.table, args.position_registers)
    check_outputs(written, [*targets, args.calibrated, args.nominal, *args.references,
                            *([args.position_registers] if args.position_registers else []),
                            *([args.payload_schedules] if args.payload_schedules else [])])
    calibrated, nominal = load_model_pair(args.calibrated, args.nominal)
    prediction = load_prediction(args.result, calibrated, written)
    tcp = {k: tool_frame(v, f"--tcp {k}=") for k, v in _named(args.tcp, "--tcp").items()}
    _check_magnitudes(args, robot_reach(nominal))
    base = None if args.robot_base is None else frame_from_text(args.robot_base, "--robot-base")
    if base is not None:  # a frame in the calibrated model's world frame (mm, deg)
        what = f"--robot-base {args.robot_base}"
        check_frame(base[:3, 3], "mm", robot_reach(nominal), what)
        check_degrees([float(v) for v in args.robot_base.replace(" ", "").split(",")][3:], what)
    res = filter_program(args.programs, calibrated, nominal, tools=_named(args.tool, "--tool"),
                         frames=_named(args.frame, "--frame"), tcp=tcp, robot_base=base,
                         dialect=args.format, references=args.references, keep_unreached=args.keep_unreached,
                         force=args.force, strict=args.strict, position_registers=args.position_registers,
                         payload=payload_si(args.payload), temperature=args.temperature,
                         payload_schedules=args.payload_schedules)
    res.warnings[:0] = unused_conditions(calibrated, args.payload, args.temperature)
    if prediction is not None and res.joints is not None:
        from robocal.trust.coverage import target_warnings

        res.warnings += target_warnings(prediction, calibrated, res.joints)
    if not res.rows:
        _diagnose_empty(args)
    res.warnings[:0] = _tool_disagreements(args)
    written = res.write({p: targets[Path(p)] for p in res.outputs}, table)
    if args.quiet:  # the warnings still matter
        for w in res.warnings:
            print(f"robocal filter: warning: {w}", file=sys.stderr)
        return 0
    print(res.summary())
    print("wrote " + ", ".join(str(p) for p in written))
    return 0
