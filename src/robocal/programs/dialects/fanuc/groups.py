"""The other motion groups of a FANUC TP position and coordinated motion.

A position of a program whose ``DEFAULT_GROUP`` holds more than the arm (``1,1,*,*,*``) carries a
block per group::

    P[3]{
       GP1:
        UF : 1, UT : 2,  CONFIG : 'N U T, 0, 0, 0',
        X = ..., W = ..., E1 = 250.000 mm     (E1..: extended axes of the arm's group)
       GP2:
        UF : 1, UT : 2,
        J1 = 30.000 deg, J2 = -45.000 deg     (the second group's axes: a positioner, a rail ...)
    };

A motion without ``COORD`` moves the second group on its own: the arm's position does not depend
on it. A motion with ``COORD`` (``L P[3] 100mm/sec CNT100 COORD``, or ``COORD[n]`` naming the
leader) moves the arm relative to the leader group's coordinated frame: the arm's position is in
that frame, which the leader's axes carry (the cell file's positioner with unit ``GPn``, its plate
frame being the coordinated frame; the position's UF number is not used). ``COORD`` in a position
of the arm's group alone moves nothing else: the position is the arm's.
"""

from __future__ import annotations

import re

import numpy as np

from robocal.programs.model import Program, Target

_AXIS = re.compile(r"\b([JE]\d{1,2})\s*=\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+))")
COORD = re.compile(r"\bCOORD\b(?:\s*\[\s*([^\]]*?)\s*\])?")
_LEADER = re.compile(r"^(?:GP|G)?\s*(\d)$", re.IGNORECASE)
BOTH = "used by motions that move differently:"  # a position one correction cannot serve (every use named)


def group_values(body: str, groups: list[re.Match]) -> dict[int, dict[str, float]]:
    """The axis values of each group after the first in a position's ``body`` (``groups``: the
    ``GPn:`` headers found in it): group number -> axis name (J1, E1 ...) -> value as written."""
    out: dict[int, dict[str, float]] = {}
    for k, g in enumerate(groups[1:], start=1):
        end = groups[k + 1].start() if k + 1 < len(groups) else len(body)
        out[int(g.group(1))] = {m.group(1): float(m.group(2)) for m in _AXIS.finditer(body, g.end(), end)}
    return out


def values_text(values: dict[str, float]) -> str:
    """``J1 = 30, J2 = -45``."""
    return ", ".join(f"{k} = {v:g}" for k, v in values.items())


def coordinate(prog: Program, t: Target, coord: re.Match | None, others: dict[int, dict[str, float]],
               extended: str, first: dict[int, tuple[str | None, dict]]) -> str:
    """Record how the motion at hand moves position ``t`` (``coord``: its ``COORD`` option, None
    without; ``others``: the position's other groups' values; ``extended``: its arm group's
    extended-axis values, as text, '' without); with ``COORD`` the position's frame
    becomes the leader's coordinated frame (:attr:`Program.carried`, the identity on the plate) and
    its :attr:`Target.axes` the leader's values (``E1``, ``E2`` ... its axes in order). ``first``:
    id(target) -> (leader unit or None, values) of its first motion. Returns why every motion
    reaching ``t`` is named ('' when it can be corrected)."""
    unit, values = None, {}
    if coord is not None and others:  # COORD in a position of the arm's group alone: nothing else moves
        if coord.group(1):
            m = _LEADER.match(coord.group(1))
            if m is None:
                return f"coordinated motion ({coord.group(0)}) with a leader this filter does not read"
            leader = int(m.group(1))
        elif len(others) == 1:
            leader = next(iter(others))
        else:
            return (f"coordinated motion (COORD) in a position of {len(others) + 1} groups: the leader is "
                    "the controller's coordinated pair, not in the program")
        if leader not in others:
            return f"coordinated with GP{leader}, but the position has no GP{leader} values"
        if extended:
            return (f"coordinated with GP{leader}, with extended axes of the arm's group too ({extended}): "
                    "an integrated axis and a leader at once are not modelled")
        unit = f"GP{leader}"
        values = {f"E{k + 1}": v for k, v in enumerate(others[leader].values())}
    seen = first.setdefault(id(t), (unit, values))
    if seen != (unit, values) and (seen[0] is not None or unit is not None):
        was, now = (f"coordinated with {u} at {values_text(v)}" if u else "not coordinated"
                    for u, v in (seen, (unit, values)))
        return (f"{BOTH} {now} here, {was} before: one corrected position cannot serve both; record a "
                "copy for each use")
    if unit is not None and t.frame != unit:
        t.axes = values
        prog.frames.setdefault(unit, np.eye(4))  # the leader's coordinated frame: the positioner's plate
        prog.carried[unit] = unit
        t.frame = unit
    return ""
