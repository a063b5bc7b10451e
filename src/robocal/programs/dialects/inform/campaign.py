"""Yaskawa INFORM campaign jobs (:mod:`robocal.campaign.programs`): a job (``/JOB``, ``//POS``,
``//INST``) with one Cartesian position per pose, ``///POSTYPE ROBOT``, ``///RECTAN``, ``///TOOL 0``
(the flange), and the form ``///RCONF`` of the planned joints (written again whenever it changes):
the controller's own IK in that form gives back the planned joints. Joint positions (``///PULSE``)
would need each axis's encoder pulses per degree, which live in the controller's parameters
(ALL.PRM), not in the model. Per pose ``MOVJ Cnnnnn VJ=speed``, ``TIMER T=settle``, ``SET I000 k`` and
``CALL JOB:procedure`` (a job of the cell that triggers the tracker and reads the pose number from
I000). X, Y, Z in mm with 3 decimals, Rx, Ry, Rz in deg with 4, as the pendant writes them; CRLF line
ends. The form tells a joint's copies apart within +-360 deg only: a planned T beyond a turn (the GP
arms' T has +-455 deg) is reached as its copy within a turn, the same flange pose.

With a positioner (`ExternalAxes`, its unit the station ``ST1``..), the job's group is ``RB1,STn``,
``///NPOS`` counts the station positions (EC), written after the robot's as ``///POSTYPE PULSE``
``///PULSE`` ``ECnnnnn=`` in encoder pulses (the axes' pulses per degree, which the controller's
parameters hold, are given: `ExternalAxes.pulses_per_unit`), and each ``MOVJ Cnnnnn ECnnnnn``
moves the arm and the station together."""

from __future__ import annotations

import re
import textwrap

import numpy as np

from robocal.core.errors import DataError
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.writing import (
    DEFAULT_PROCEDURE,
    DEFAULT_SETTLE_S,
    DEFAULT_SPEED_PERCENT,
    EXTERNAL_LETTERS,
    ExternalAxes,
    ascii_comment,
    checked_external,
    checked_joints,
    comment_lines,
    identifier,
)

INFORM_NAME_MAX = 32               # YRC1000 job names
INFORM_DECIMALS = (3, 4)           # mm, deg: the pendant's RECTAN precision
INFORM_COMMENT_MAX = 32            # characters of ///COMM and of a ' comment
STATION_RE = r"(?:ST|S)([1-9])"     # a station's name in a cell file: ST1 or S1 (the job says ST1)


def inform_job(joints_deg, robot, name: str = "ROBOCAL_CAMPAIGN", *, dialect: Dialect,
               speed_percent: float = DEFAULT_SPEED_PERCENT, settle_s: float = DEFAULT_SETTLE_S,
               procedure: str = DEFAULT_PROCEDURE, comment: str = "",
               external: ExternalAxes | None = None) -> str:
    """Yaskawa INFORM job visiting ``joints_deg (N, 6)`` in order on ``robot`` (its nominal model:
    the RECTAN positions are its flange poses in the robot frame, see the module docstring) in
    ``dialect``'s notation (:class:`~robocal.programs.dialects.inform.reader.InformDialect`), the
    station ``external`` with it."""
    q = checked_joints(joints_deg, speed_percent, settle_s, "INFORM")
    external = checked_external(external, len(q), "INFORM")
    station, pulses = _station(external)
    name = identifier(name, "the INFORM job name (the file name)", INFORM_NAME_MAX).upper()
    procedure = identifier(procedure, "the procedure (job) name", INFORM_NAME_MAX).upper()
    rad = np.deg2rad(q)
    values = dialect.from_pose(robot.fk(rad), np.zeros((len(q), 6)))
    form = dialect.scheme.encode(robot, rad)
    pos = ["/JOB", f"//NAME {name}", "//POS", f"///NPOS {len(q)},0,{len(q) if station else 0},0,0,0",
           "///TOOL 0", "///POSTYPE ROBOT",
           "///RECTAN"]
    last = None
    for k, (row, cfg) in enumerate(zip(values, form, strict=True)):
        text = dialect.scheme.text(cfg)
        if text != last:
            pos.append(f"///RCONF {text},0,0")
            last = text
        digits = [INFORM_DECIMALS[0]] * 3 + [INFORM_DECIMALS[1]] * 3
        pos.append(f"C{k:05d}=" + ",".join(_fixed(v, d) for v, d in zip(row, digits, strict=True)))
    if station:
        pos += ["///POSTYPE PULSE", "///PULSE"]
        pos += [f"EC{k:05d}=" + ",".join(str(int(v)) for v in row) for k, row in enumerate(pulses)]
    texts = [*comment_lines(comment, len(q)), f"{procedure} reads the pose number from I000"]
    notes = [line for text in texts for line in textwrap.wrap(ascii_comment(text), INFORM_COMMENT_MAX)]
    inst = ["//INST", "///DATE 2000/01/01 00:00", f"///COMM {notes[0]}", "///ATTR SC,RW",
            "///GROUP1 RB1" + (f",{station}" if station else ""), "NOP"]
    inst += [f"'{line}" for line in notes]
    for k in range(len(q)):
        move = f"MOVJ C{k:05d}" + (f" EC{k:05d}" if station else "")
        inst += [f"{move} VJ={speed_percent:.2f}", f"TIMER T={settle_s:.2f}", f"SET I000 {k + 1}",
                 f"CALL JOB:{procedure}"]
    return "\r\n".join([*pos, *inst, "END", ""])


def _station(external: ExternalAxes | None) -> tuple[str, np.ndarray | None]:
    """The station's name in the job (``ST1``; '' without one) and its positions in encoder pulses
    ``(N, m)`` (integers; the axes in their order E1..)."""
    if external is None:
        return "", None
    match = re.fullmatch(STATION_RE, external.unit.upper())
    if not match:
        raise DataError(f"an INFORM positioner's unit is its station ST1..ST9 (or S1..), got "
                        f"{external.unit!r}")
    if external.pulses_per_unit is None:
        raise DataError(f"INFORM writes {external.unit}'s positions in encoder pulses: give each axis' "
                        "pulses per degree (mm), from the controller's parameters")
    slots = external.slots(EXTERNAL_LETTERS, "INFORM")
    if sorted(slots) != list(range(len(slots))):
        raise DataError(f"{external.unit}: a station's axes are E1..E{len(slots)}, got "
                        f"{', '.join(external.axes)}")
    order = np.argsort(slots)
    ratio = np.array(external.pulses_per_unit)[order]
    return f"ST{match.group(1)}", np.round(external.values[:, order] * ratio)


def _fixed(value: float, decimals: int) -> str:
    """``value`` with exactly ``decimals`` decimals, never '-0.000'."""
    text = f"{value:.{decimals}f}"
    return text.lstrip("-") if float(text) == 0.0 else text
