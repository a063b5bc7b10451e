"""FANUC TP campaign programs (:mod:`robocal.campaign.programs`): an ASCII ``.ls`` program (``/PROG``,
``/ATTR``, ``/MN``, ``/POS``, ``/END``) with ``UFRAME_NUM=0``, ``UTOOL_NUM=0``, per pose ``J P[k] speed%
FINE``, ``WAIT``, ``CALL procedure(k)`` (a TP program of the cell that triggers the tracker), and joint
positions ``J1= .. deg`` in ``/POS``. FANUC controllers count J3 from the horizontal, not from the upper
arm as the catalog (ROS-Industrial's joint_3) does: the TP value is J3 + J23_FACTOR * J2
(ROS-Industrial fanuc_driver's J3_out = J3_in + J23_factor * J2_in, J23_factor 1 for its arms).
With a positioner (`ExternalAxes`, its unit the motion group ``GPn``), the program's
``DEFAULT_GROUP`` holds both groups and every ``P[k]`` a ``GPn:`` section with its axes ``J1=``..
(deg; mm on a prismatic axis): each ``J P[k]`` moves the arm and the table together."""

from __future__ import annotations

import re
import textwrap

from robocal.core.errors import DataError
from robocal.data.joint_conventions import J23_FACTOR  # FANUC J3 (TP) = J3 (catalog) + J23_FACTOR * J2
from robocal.programs.dialects.writing import (
    DEFAULT_PROCEDURE,
    DEFAULT_SETTLE_S,
    DEFAULT_SPEED_PERCENT,
    EXTERNAL_LETTERS,
    PROGRAM_JOINTS,
    ExternalAxes,
    ascii_comment,
    checked_external,
    checked_joints,
    comment_lines,
    fixed_point,
    identifier,
)

TP_REMARK_WIDTH = 30  # characters of one FANUC TP remark line (! ...)

TP_NAME_MAX = 36                   # R-30iB program names
TP_DECIMALS = 4                    # TP stores single-precision joint values
SCARA_JOINTS = 4                   # an SR-series arm: J1, J2, the quill J3, J4
MOTION_GROUPS = 5                  # DEFAULT_GROUP's fields (R-30iB: up to 5 motion groups)


def fanuc_ls_program(joints_deg, name: str = "ROBOCAL_CAMPAIGN", *,
                     speed_percent: float = DEFAULT_SPEED_PERCENT, settle_s: float = DEFAULT_SETTLE_S,
                     procedure: str = DEFAULT_PROCEDURE, comment: str = "", scara: bool = False,
                     external: ExternalAxes | None = None) -> str:
    """FANUC TP ``.ls`` text visiting ``joints_deg (N, 6)`` (catalog convention) in order, the
    positioner ``external`` (a motion group ``GPn``) with it; with ``scara``, an SR-series arm's
    ``(N, 4)``: J1, J2, J4 in deg and the quill J3 in mm, as given (no J2/J3 coupling on a SCARA)."""
    q = checked_joints(joints_deg, speed_percent, settle_s, "FANUC TP", SCARA_JOINTS if scara
                       else PROGRAM_JOINTS).copy()
    external = checked_external(external, len(q), "FANUC TP")
    group, slots = _group(external)
    name = identifier(name, "the TP program name (the file name)", TP_NAME_MAX).upper()
    procedure = identifier(procedure, "the procedure (TP program) name", TP_NAME_MAX).upper()
    trigger = f"{procedure} is a TP program of yours that triggers the tracker (its argument: the pose " \
        "number)"
    if scara:
        notes = [*comment_lines(comment, len(q)), f"J3 is the quill in mm; {trigger}"]
    else:
        q[:, 2] += J23_FACTOR * q[:, 1]
        notes = [*comment_lines(comment, len(q)),
                 f"J3 is FANUC's (from the horizontal): catalog J3 + J2; {trigger}"]
    body = ["  UFRAME_NUM=0 ;", "  UTOOL_NUM=0 ;"]
    for k in range(1, len(q) + 1):
        body += [f"J P[{k}] {max(1, round(speed_percent))}% FINE    ;",
                 f"  WAIT {settle_s:6.2f}(sec) ;", f"  CALL {procedure}({k}) ;"]
    remarks = [f"  !{line} ;" for note in notes
               for line in textwrap.wrap(ascii_comment(note.replace(";", ",")), TP_REMARK_WIDTH)]
    lines = [f"/PROG  {name}", "/ATTR", "OWNER\t\t= MNEDITOR;",
             f'COMMENT\t\t= "{ascii_comment(comment)[:16]}";',
             "PROG_SIZE\t= 0;", "CREATE\t\t= DATE 00-01-01  TIME 00:00:00;",
             "MODIFIED\t= DATE 00-01-01  TIME 00:00:00;", "FILE_NAME\t= ;", "VERSION\t\t= 0;",
             f"LINE_COUNT\t= {len(remarks) + len(body)};", "MEMORY_SIZE\t= 0;", "PROTECT\t\t= READ_WRITE;",
             "TCD:  STACK_SIZE\t= 0,", "      TASK_PRIORITY\t= 50,", "      TIME_SLICE\t= 0,",
             "      BUSY_LAMP_OFF\t= 0,", "      ABORT_REQUEST\t= 0,", "      PAUSE_REQUEST\t= 0;",
             "DEFAULT_GROUP\t= " + ",".join("1" if g in (1, group) else "*"
                                             for g in range(1, MOTION_GROUPS + 1)) + ";",
             "CONTROL_CODE\t= 00000000 00000000;", "/MN"]
    lines += [f"{i:4d}:{text}" for i, text in enumerate([*remarks, *body], start=1)]
    lines.append("/POS")
    for k, row in enumerate(q, start=1):
        v = [fixed_point(x, TP_DECIMALS) for x in row]
        lines += [f"P[{k}]{{", "   GP1:", "\tUF : 0, UT : 0,"]
        if scara:
            lines.append(f"\tJ1= {v[0]} deg,\tJ2= {v[1]} deg,\tJ3= {v[2]} mm,\tJ4= {v[3]} deg")
        else:
            lines += [f"\tJ1= {v[0]} deg,\tJ2= {v[1]} deg,\tJ3= {v[2]} deg,",
                      f"\tJ4= {v[3]} deg,\tJ5= {v[4]} deg,\tJ6= {v[5]} deg"]
        if external is not None:
            axes = sorted(zip(slots, external.values[k - 1], external.units(), strict=True))
            lines += [f"   GP{group}:", "\tUF : 0, UT : 0,",
                      "\t" + ",\t".join(f"J{j + 1}= {fixed_point(x, TP_DECIMALS)} {u}" for j, x, u in axes)]
        lines.append("};")
    return "\n".join([*lines, "/END", ""])


def _group(external: ExternalAxes | None) -> tuple[int, list[int]]:
    """The motion group number of the positioner's unit (``GP2`` -> 2; 0 without one) and its axes'
    places ``J1``.. in the group (from ``E1``..)."""
    if external is None:
        return 0, []
    match = re.fullmatch(r"GP([2-9])", external.unit.upper())
    if not match or int(match.group(1)) > MOTION_GROUPS:
        raise DataError(f"a FANUC positioner's unit is its motion group GP2..GP{MOTION_GROUPS}, got "
                        f"{external.unit!r}")
    return int(match.group(1)), external.slots(EXTERNAL_LETTERS, "FANUC")
