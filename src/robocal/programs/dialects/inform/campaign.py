"""Yaskawa INFORM campaign jobs (:mod:`robocal.campaign.programs`): a job (``/JOB``, ``//POS``,
``//INST``) with one Cartesian position per pose, ``///POSTYPE ROBOT``, ``///RECTAN``, ``///TOOL 0``
(the flange), and the form ``///RCONF`` of the planned joints (written again whenever it changes):
the controller's own IK in that form gives back the planned joints. Joint positions (``///PULSE``)
would need each axis's encoder pulses per degree, which live in the controller's parameters
(ALL.PRM), not in the model. Per pose ``MOVJ Cnnnnn VJ=speed``, ``TIMER T=settle``, ``SET I000 k`` and
``CALL JOB:procedure`` (a job of the cell that triggers the tracker and reads the pose number from
I000). X, Y, Z in mm with 3 decimals, Rx, Ry, Rz in deg with 4, as the pendant writes them; CRLF line
ends. The form tells a joint's copies apart within +-360 deg only: a planned T beyond a turn (the GP
arms' T has +-455 deg) is reached as its copy within a turn, the same flange pose."""

from __future__ import annotations

import textwrap

import numpy as np

from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.writing import (
    DEFAULT_PROCEDURE,
    DEFAULT_SETTLE_S,
    DEFAULT_SPEED_PERCENT,
    ascii_comment,
    checked_joints,
    comment_lines,
    identifier,
)

INFORM_NAME_MAX = 32               # YRC1000 job names
INFORM_DECIMALS = (3, 4)           # mm, deg: the pendant's RECTAN precision
INFORM_COMMENT_MAX = 32            # characters of ///COMM and of a ' comment


def inform_job(joints_deg, robot, name: str = "ROBOCAL_CAMPAIGN", *, dialect: Dialect,
               speed_percent: float = DEFAULT_SPEED_PERCENT, settle_s: float = DEFAULT_SETTLE_S,
               procedure: str = DEFAULT_PROCEDURE, comment: str = "") -> str:
    """Yaskawa INFORM job visiting ``joints_deg (N, 6)`` in order on ``robot`` (its nominal model:
    the RECTAN positions are its flange poses in the robot frame, see the module docstring) in
    ``dialect``'s notation (:class:`~robocal.programs.dialects.inform.reader.InformDialect`)."""
    q = checked_joints(joints_deg, speed_percent, settle_s, "INFORM")
    name = identifier(name, "the INFORM job name (the file name)", INFORM_NAME_MAX).upper()
    procedure = identifier(procedure, "the procedure (job) name", INFORM_NAME_MAX).upper()
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
    texts = [*comment_lines(comment, len(q)), f"{procedure} reads the pose number from I000"]
    notes = [line for text in texts for line in textwrap.wrap(ascii_comment(text), INFORM_COMMENT_MAX)]
    inst = ["//INST", "///DATE 2000/01/01 00:00", f"///COMM {notes[0]}", "///ATTR SC,RW", "///GROUP1 RB1",
            "NOP"]
    inst += [f"'{line}" for line in notes]
    for k in range(len(q)):
        inst += [f"MOVJ C{k:05d} VJ={speed_percent:.2f}", f"TIMER T={settle_s:.2f}", f"SET I000 {k + 1}",
                 f"CALL JOB:{procedure}"]
    return "\r\n".join([*pos, *inst, "END", ""])


def _fixed(value: float, decimals: int) -> str:
    """``value`` with exactly ``decimals`` decimals, never '-0.000'."""
    text = f"{value:.{decimals}f}"
    return text.lstrip("-") if float(text) == 0.0 else text
