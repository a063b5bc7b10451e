"""Robot programs that drive a measurement campaign: ABB RAPID, KUKA KRL, FANUC TP (.ls), Universal
Robots URScript, Yaskawa INFORM (.JBI), Staubli VAL3 (an application folder).

Each program moves to the planned joint positions in the measuring order, waits ``settle_s``
seconds for the robot to come to rest, and calls a named procedure at each pose where the user
triggers the tracker (the generated procedure only shows a message: replace its body with the
cell's trigger, a digital output or a socket message). Joint values are written in the robot's
own joint convention: the catalog's joint zeros and signs are the controller's, so the planned
values go out unchanged (degrees for RAPID and KRL, radians for URScript).

- RAPID: one module with ``CONST jointtarget`` data, ``PROC main()`` (``VelSet`` to the speed
  percentage, then ``MoveAbsJ ... fine, tool0``, ``WaitTime``, the procedure call per pose) and the
  procedure ``PROC name(num pose)``; external axes are 9E9 (none).
- KRL: a ``.src`` (``BAS(#INITMOV,0)``, ``BAS(#VEL_PTP, speed)``, then per pose ``PTP XPk``,
  ``WAIT SEC``, the procedure call) and its ``.dat`` declaring ``DECL AXIS XPk={A1 ..,A6 ..}``
  (AXIS, not E6AXIS, so that no external axis moves).
- FANUC TP: an ASCII ``.ls`` program (``/PROG``, ``/ATTR``, ``/MN``, ``/POS``, ``/END``) with
  ``UFRAME_NUM=0``, ``UTOOL_NUM=0``, per pose ``J P[k] speed% FINE``, ``WAIT``, ``CALL
  procedure(k)`` (a TP program of the cell that triggers the tracker), and joint positions
  ``J1= .. deg`` in ``/POS``. FANUC controllers count J3 from the horizontal, not from the upper
  arm as the catalog (ROS-Industrial's joint_3) does: the TP value is J3 + J23_FACTOR * J2
  (ROS-Industrial fanuc_driver's J3_out = J3_in + J23_factor * J2_in, J23_factor 1 for its arms).
- URScript: a program ``def name(): ... end`` with ``movej([q1, .., q6], a=.., v=..)``, where
  ``v`` is the speed percentage of pi rad/s (Universal Robots' joint speed limit) and ``a`` 1.4
  rad/s^2, ``sleep`` and the procedure, defined inside the program.
- INFORM: a job (``/JOB``, ``//POS``, ``//INST``) with one Cartesian position per pose,
  ``///POSTYPE ROBOT``, ``///RECTAN``, ``///TOOL 0`` (the flange), and the form ``///RCONF`` of the
  planned joints (written again whenever it changes): the controller's own IK in that form gives
  back the planned joints. Joint positions (``///PULSE``) would need each axis's encoder pulses per
  degree, which live in the controller's parameters (ALL.PRM), not in the model. Per pose
  ``MOVJ Cnnnnn VJ=speed``, ``TIMER T=settle``, ``SET I000 k`` and ``CALL JOB:procedure`` (a job of
  the cell that triggers the tracker and reads the pose number from I000). X, Y, Z in mm with 3
  decimals, Rx, Ry, Rz in deg with 4, as the pendant writes them; CRLF line ends. The form tells a
  joint's copies apart within +-360 deg only: a planned T beyond a turn (the GP arms' T has
  +-455 deg) is reached as its copy within a turn, the same flange pose.
- VAL3: an application folder NAME/ with ``NAME.pjx``, ``start.pgx`` (per pose ``movej(jPose[k],
  flange, mCampaign)``, ``waitEndMove()``, ``delay(settle)``, ``call procedure(k)``), ``stop.pgx``,
  the procedure's ``.pgx`` (a ``num`` parameter; its body only writes a message) and ``NAME.dtx``
  declaring ``jPose`` (jointRx, deg) and ``mCampaign`` (mdesc, ``vel`` = the speed percentage,
  blend off). XML as the Staubli editor writes it (UTF-8, CRLF).
"""

from __future__ import annotations

import re
import textwrap

import numpy as np

from robocal.core.errors import DataError
from robocal.data.joint_conventions import J23_FACTOR  # FANUC J3 (TP) = J3 (catalog) + J23_FACTOR * J2
from robocal.trust.output_marker import TP_REMARK_WIDTH  # characters of one TP remark line (! ...)

PROGRAM_JOINTS = 6                 # every language here drives a six-axis arm (A1..A6, robax_a..f)
UR_MAX_JOINT_SPEED = np.pi         # rad/s, Universal Robots' joint speed limit
UR_ACCELERATION = 1.4              # rad/s^2, Polyscope's default joint acceleration
RAPID_NAME_MAX = 32
TP_NAME_MAX = 36                   # R-30iB program names
TP_DECIMALS = 4                    # TP stores single-precision joint values
KRL_NAME_MAX = 24
INFORM_NAME_MAX = 32               # YRC1000 job names
INFORM_DECIMALS = (3, 4)           # mm, deg: the pendant's RECTAN precision
INFORM_COMMENT_MAX = 32            # characters of ///COMM and of a ' comment
VAL3_NAME_MAX = 15                 # VAL3 application and program names (CS8 limit)
DEGREE_DECIMALS = 10               # written precision of joint values in degrees
RADIAN_DECIMALS = 12               # ... in radians
DEFAULT_SPEED_PERCENT = 20.0
DEFAULT_SETTLE_S = 1.0
DEFAULT_PROCEDURE = "MeasurePose"


def fixed_point(value: float, decimals: int) -> str:
    """Fixed-point text without exponent or trailing zeros (every controller parses it)."""
    text = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _identifier(name: str, what: str, limit: int) -> str:
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name or "") or len(name) > limit:
        raise DataError(f"{what} {name!r} is not a valid identifier: a letter, then letters, digits or "
                        f"underscores, at most {limit} characters")
    return name


def _check(joints_deg: np.ndarray, speed_percent: float, settle_s: float, language: str) -> np.ndarray:
    q = np.asarray(joints_deg, dtype=float)
    if q.ndim != 2 or q.shape[1] != PROGRAM_JOINTS:
        raise DataError(f"a {language} campaign program drives a {PROGRAM_JOINTS}-axis robot; this robot has "
                        f"{q.shape[-1]} joints")
    if not np.isfinite(q).all():
        raise DataError("joint values must be finite")
    if not 0 < speed_percent <= 100:
        raise DataError(f"the speed must be a percentage in (0, 100], got {speed_percent}")
    if not 0 <= settle_s < 3600:
        raise DataError(f"the settle time must be in [0, 3600) s, got {settle_s}")
    return q


def rapid_module(joints_deg, name: str = "RobocalCampaign", *, speed_percent: float = DEFAULT_SPEED_PERCENT,
                 settle_s: float = DEFAULT_SETTLE_S, procedure: str = DEFAULT_PROCEDURE,
                 comment: str = "") -> str:
    """ABB RAPID program module visiting ``joints_deg (N, 6)`` in order (see module docstring)."""
    q = _check(joints_deg, speed_percent, settle_s, "RAPID")
    name = _identifier(name, "the RAPID module name", RAPID_NAME_MAX)
    procedure = _identifier(procedure, "the procedure name", RAPID_NAME_MAX)
    lines = [f"MODULE {name}"]
    lines += [f"    ! {line}" for line in _comment_lines(comment, len(q))]
    for k, row in enumerate(q, start=1):
        values = ",".join(fixed_point(v, DEGREE_DECIMALS) for v in row)
        lines.append(f"    CONST jointtarget jt{k} := [[{values}],[9E9,9E9,9E9,9E9,9E9,9E9]];")
    lines += ["", "    PROC main()", f"        VelSet {fixed_point(speed_percent, 3)}, 5000;"]
    for k in range(1, len(q) + 1):
        lines += [f"        MoveAbsJ jt{k}\\NoEOffs, v1000, fine, tool0;",
                  f"        WaitTime {fixed_point(settle_s, 3)};", f"        {procedure} {k};"]
    lines += ["    ENDPROC", "", f"    PROC {procedure}(num pose)",
              "        ! trigger the tracker measurement here (e.g. SetDO, a socket message)",
              '        TPWrite "robocal: measure pose "\\Num:=pose;', "    ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)


def krl_program(joints_deg, name: str = "robocal_campaign", *, speed_percent: float = DEFAULT_SPEED_PERCENT,
                settle_s: float = DEFAULT_SETTLE_S, procedure: str = DEFAULT_PROCEDURE,
                comment: str = "") -> tuple[str, str]:
    """KUKA KRL ``(.src text, .dat text)`` visiting ``joints_deg (N, 6)`` in order."""
    q = _check(joints_deg, speed_percent, settle_s, "KRL")
    name = _identifier(name, "the KRL program name (the file name)", KRL_NAME_MAX)
    procedure = _identifier(procedure, "the procedure name", KRL_NAME_MAX)
    head = ["&ACCESS RVP", "&REL 1"]
    src = head + [f"DEF {name}( )"] + [f"  ; {line}" for line in _comment_lines(comment, len(q))]
    src += [";FOLD INI", "  BAS (#INITMOV,0 )", ";ENDFOLD",
            f"  BAS (#VEL_PTP,{fixed_point(speed_percent, 3)} )"]
    for k in range(1, len(q) + 1):
        src += [f"  PTP XP{k}", f"  WAIT SEC {fixed_point(settle_s, 3)}", f"  {procedure}({k})"]
    src += ["END", "", f"DEF {procedure}(POSE:IN )", "  INT POSE",
            "  ; trigger the tracker measurement of pose POSE here (e.g. $OUT[...] = TRUE)", "END", ""]
    dat = head + [f"DEFDAT {name}"]
    for k, row in enumerate(q, start=1):
        axes = ",".join(f"A{i + 1} {fixed_point(v, DEGREE_DECIMALS)}" for i, v in enumerate(row))
        dat.append(f"  DECL AXIS XP{k}={{{axes}}}")
    dat += ["ENDDAT", ""]
    return "\n".join(src), "\n".join(dat)


def fanuc_ls_program(joints_deg, name: str = "ROBOCAL_CAMPAIGN", *,
                     speed_percent: float = DEFAULT_SPEED_PERCENT, settle_s: float = DEFAULT_SETTLE_S,
                     procedure: str = DEFAULT_PROCEDURE, comment: str = "") -> str:
    """FANUC TP ``.ls`` text visiting ``joints_deg (N, 6)`` (catalog convention) in order."""
    q = _check(joints_deg, speed_percent, settle_s, "FANUC TP").copy()
    name = _identifier(name, "the TP program name (the file name)", TP_NAME_MAX).upper()
    procedure = _identifier(procedure, "the procedure (TP program) name", TP_NAME_MAX).upper()
    q[:, 2] += J23_FACTOR * q[:, 1]
    notes = [*_comment_lines(comment, len(q)),
             f"J3 is FANUC's (from the horizontal): catalog J3 + J2; {procedure} is a TP program of yours "
             "that triggers the tracker (its argument: the pose number)"]
    body = ["  UFRAME_NUM=0 ;", "  UTOOL_NUM=0 ;"]
    for k in range(1, len(q) + 1):
        body += [f"J P[{k}] {max(1, round(speed_percent))}% FINE    ;",
                 f"  WAIT {settle_s:6.2f}(sec) ;", f"  CALL {procedure}({k}) ;"]
    remarks = [f"  !{line} ;" for note in notes
               for line in textwrap.wrap(_tp_text(note.replace(";", ",")), TP_REMARK_WIDTH)]
    lines = [f"/PROG  {name}", "/ATTR", "OWNER\t\t= MNEDITOR;", f'COMMENT\t\t= "{_tp_text(comment)[:16]}";',
             "PROG_SIZE\t= 0;", "CREATE\t\t= DATE 00-01-01  TIME 00:00:00;",
             "MODIFIED\t= DATE 00-01-01  TIME 00:00:00;", "FILE_NAME\t= ;", "VERSION\t\t= 0;",
             f"LINE_COUNT\t= {len(remarks) + len(body)};", "MEMORY_SIZE\t= 0;", "PROTECT\t\t= READ_WRITE;",
             "TCD:  STACK_SIZE\t= 0,", "      TASK_PRIORITY\t= 50,", "      TIME_SLICE\t= 0,",
             "      BUSY_LAMP_OFF\t= 0,", "      ABORT_REQUEST\t= 0,", "      PAUSE_REQUEST\t= 0;",
             "DEFAULT_GROUP\t= 1,*,*,*,*;", "CONTROL_CODE\t= 00000000 00000000;", "/MN"]
    lines += [f"{i:4d}:{text}" for i, text in enumerate([*remarks, *body], start=1)]
    lines.append("/POS")
    for k, row in enumerate(q, start=1):
        v = [fixed_point(x, TP_DECIMALS) for x in row]
        lines += [f"P[{k}]{{", "   GP1:", "\tUF : 0, UT : 0,",
                  f"\tJ1= {v[0]} deg,\tJ2= {v[1]} deg,\tJ3= {v[2]} deg,",
                  f"\tJ4= {v[3]} deg,\tJ5= {v[4]} deg,\tJ6= {v[5]} deg", "};"]
    return "\n".join([*lines, "/END", ""])


def inform_job(joints_deg, robot, name: str = "ROBOCAL_CAMPAIGN", *,
               speed_percent: float = DEFAULT_SPEED_PERCENT, settle_s: float = DEFAULT_SETTLE_S,
               procedure: str = DEFAULT_PROCEDURE, comment: str = "") -> str:
    """Yaskawa INFORM job visiting ``joints_deg (N, 6)`` in order on ``robot`` (its nominal model:
    the RECTAN positions are its flange poses in the robot frame, see the module docstring)."""
    from robocal.programs.inform import InformDialect

    q = _check(joints_deg, speed_percent, settle_s, "INFORM")
    name = _identifier(name, "the INFORM job name (the file name)", INFORM_NAME_MAX).upper()
    procedure = _identifier(procedure, "the procedure (job) name", INFORM_NAME_MAX).upper()
    dialect = InformDialect()
    rad = np.deg2rad(q)
    values = dialect.from_pose(robot.fk(rad), np.zeros((len(q), 6)))
    form = dialect.scheme.encode(robot, rad)
    pos = ["/JOB", f"//NAME {name}", "//POS", f"///NPOS {len(q)},0,0,0,0,0", "///TOOL 0", "///POSTYPE ROBOT",
           "///RECTAN"]
    last = None
    for k, (row, cfg) in enumerate(zip(values, form, strict=True)):
        text = dialect.scheme.text(cfg)
        if text != last:
            pos.append(f"///RCONF {text},0,0")
            last = text
        digits = [INFORM_DECIMALS[0]] * 3 + [INFORM_DECIMALS[1]] * 3
        pos.append(f"C{k:05d}=" + ",".join(_fixed(v, d) for v, d in zip(row, digits, strict=True)))
    texts = [*_comment_lines(comment, len(q)), f"{procedure} reads the pose number from I000"]
    notes = [line for text in texts for line in textwrap.wrap(_tp_text(text), INFORM_COMMENT_MAX)]
    inst = ["//INST", "///DATE 2000/01/01 00:00", f"///COMM {notes[0]}", "///ATTR SC,RW", "///GROUP1 RB1",
            "NOP"]
    inst += [f"'{line}" for line in notes]
    for k in range(len(q)):
        inst += [f"MOVJ C{k:05d} VJ={speed_percent:.2f}", f"TIMER T={settle_s:.2f}", f"SET I000 {k + 1}",
                 f"CALL JOB:{procedure}"]
    return "\r\n".join([*pos, *inst, "END", ""])


def val3_application(joints_deg, name: str = "robocalCampaign", *,
                     speed_percent: float = DEFAULT_SPEED_PERCENT, settle_s: float = DEFAULT_SETTLE_S,
                     procedure: str = DEFAULT_PROCEDURE, comment: str = "") -> dict[str, str]:
    """Staubli VAL3 application visiting ``joints_deg (N, 6)`` in order: file name -> text (see the
    module docstring)."""
    q = _check(joints_deg, speed_percent, settle_s, "VAL3")
    name = _identifier(name, "the VAL3 application name (the folder name)", VAL3_NAME_MAX)
    procedure = _identifier(procedure, "the procedure (program) name", VAL3_NAME_MAX)
    if procedure in ("start", "stop"):
        raise DataError(f"the procedure cannot be named {procedure}: start and stop are the application's")
    head = '<?xml version="1.0" encoding="utf-8"?>'
    ns = 'xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xmlns="http://www.staubli.com/robotics/VAL3'
    code = ["begin", *(f"  // {line}" for line in _comment_lines(comment, len(q)))]
    for k in range(len(q)):
        code += [f"  movej(jPose[{k}], flange, mCampaign)", "  waitEndMove()",
                 f"  delay({fixed_point(settle_s, 3)})", f"  call {procedure}({k + 1})"]
    code.append("end")

    def pgx(prog: str, body: list[str], params: tuple[str, ...] = ()) -> str:
        return "\n".join([head, f'<Programs {ns}/Program/2">', f'  <Program name="{prog}" access="public">',
                          *params, "    <Code><![CDATA[" + "\n".join(body), "]]></Code>", "  </Program>",
                          "</Programs>", ""])

    data = '    <Data name="{}" access="public" xsi:type="array" type="{}" size="{}">'
    dtx = [head, f'<Database {ns}/Data/2">', "  <Datas>", data.format("jPose", "jointRx", len(q))]
    for k, row in enumerate(q):
        joints = " ".join(f'j{i + 1}="{fixed_point(v, DEGREE_DECIMALS)}"' for i, v in enumerate(row))
        dtx.append(f'      <Value key="{k}" {joints} />')
    dtx += ["    </Data>", data.format("mCampaign", "mdesc", 1),
            f'      <Value key="0" vel="{fixed_point(speed_percent, 3)}" blend="off" />', "    </Data>",
            "  </Datas>", "</Database>", ""]
    pjx = [head, '<Project xmlns="http://www.staubli.com/robotics/VAL3/Project/3">',
           '  <Parameters version="s7.11" stackSize="5000" millimeterUnit="true" />', "  <Programs>",
           *(f'    <Program file="{f}.pgx" />' for f in ("start", "stop", procedure)), "  </Programs>",
           "  <Database>", f'    <Data file="{name}.dtx" />', "  </Database>", "  <Libraries />",
           "</Project>", ""]
    param = ('    <Parameters xmlns="http://www.staubli.com/robotics/VAL3/Param/1">',
             '      <Parameter name="x_nPose" type="num" xsi:type="element" />', "    </Parameters>")
    measure = ["begin", "  // trigger the tracker measurement here",
               '  putln("robocal: measure pose " + toString("", x_nPose))', "end"]
    files = {f"{name}.pjx": "\n".join(pjx), "start.pgx": pgx("start", code),
             "stop.pgx": pgx("stop", ["begin", "  resetMotion()", "end"]),
             f"{procedure}.pgx": pgx(procedure, measure, param), f"{name}.dtx": "\n".join(dtx)}
    return {k: v.replace("\n", "\r\n") for k, v in files.items()}


def _fixed(value: float, decimals: int) -> str:
    """``value`` with exactly ``decimals`` decimals, never '-0.000'."""
    text = f"{value:.{decimals}f}"
    return text.lstrip("-") if float(text) == 0.0 else text


def _tp_text(text: str) -> str:
    """Printable ASCII without quotes (a TP comment)."""
    return "".join(ch if 32 <= ord(ch) < 127 and ch not in "\"'" else " " for ch in text)


def urscript_program(joints_rad, name: str = "robocal_campaign", *,
                     speed_percent: float = DEFAULT_SPEED_PERCENT, settle_s: float = DEFAULT_SETTLE_S,
                     procedure: str = DEFAULT_PROCEDURE, comment: str = "") -> str:
    """URScript program visiting ``joints_rad (N, 6)`` (radians) in order."""
    q = _check(joints_rad, speed_percent, settle_s, "URScript")
    name = _identifier(name, "the URScript program name", RAPID_NAME_MAX)
    procedure = _identifier(procedure, "the procedure name", RAPID_NAME_MAX)
    v = UR_MAX_JOINT_SPEED * speed_percent / 100.0
    lines = [f"def {name}():"] + [f"  # {line}" for line in _comment_lines(comment, len(q))]
    lines += [f"  def {procedure}(pose):",
              "    # trigger the tracker measurement here (e.g. set_digital_out)",
              '    textmsg("robocal: measure pose ", pose)', "  end"]
    for k, row in enumerate(q, start=1):
        values = ", ".join(fixed_point(x, RADIAN_DECIMALS) for x in row)
        lines += [f"  movej([{values}], a={fixed_point(UR_ACCELERATION, 3)}, v={fixed_point(v, 4)})",
                  f"  sleep({fixed_point(settle_s, 3)})", f"  {procedure}({k})"]
    lines += ["end", ""]
    return "\n".join(lines)


def _comment_lines(comment: str, n: int) -> list[str]:
    """Comment text for a program header: printable ASCII only (controllers' comment charset)."""
    text = comment or f"robocal measurement campaign: {n} poses"
    clean = "".join(ch if 32 <= ord(ch) < 127 else "?" for ch in text)
    return [clean[i : i + 100] for i in range(0, len(clean), 100)] + [
        "joint values in the controller's joint convention; replace the measure procedure's body "
        "with your tracker trigger"]
