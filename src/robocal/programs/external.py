"""Targets with external-axis values (a track or gantry moving the robot, a positioner moving the
work: RAPID ``extax`` not 9E9, KUKA E1..E6 not 0, FANUC E1.. values or a second motion group),
sorted before filtering by what the values do to the target:

* a target in a frame a mechanical unit carries (:attr:`Program.carried`: a RAPID work object
  with ``ufmec``, a KRL base on an external kinematic ...) moves with that unit: with a cell
  model whose positioner has that unit it is corrected (:mod:`robocal.programs.positioner`, which
  takes those targets first); otherwise every motion that reaches it is named with the unit and
  the cell file to give;
* a target whose dialect read its axis values (:attr:`Target.axes`) in a frame no unit carries:
  the values do not move it relative to the arm (an uncoordinated positioner, a turntable the
  program only indexes): it is corrected as an arm target, and one summary warning says how many
  such targets there were and that a track or gantry carrying the arm needs its cell file;
  such a target the fixed arm cannot reach (or not in its configuration) is named with its values
  (:func:`unreached_reason`), which may move the arm (a track); unless the user declared that no
  external axis carries the arm (``fixed_base``), the values of the axes the dialect says may carry
  it (:attr:`Dialect.arm_axes`: a RAPID ``eax_a``, a KRL ``E1``) are weighed first
  (:func:`robocal.programs.carrier.arm_carriers`): the targets with an axis that carries the arm, or
  may (too few targets to judge, a linear axis the targets do not follow), are named with why, but
  those at the axis' zero (the arm where its model has it, as a KRL E6POS whose E1..E6 are all 0);
* a target whose values the dialect gives as text only (no :attr:`Target.axes`): where it is
  depends on axes the filter does not model, so it is set aside and every motion that reaches
  it is named with the values.

A track cell takes its targets first (:mod:`robocal.programs.track`). This module is kept apart
from the filter so that each cell model takes its targets in one place.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robocal.programs.carrier import arm_carriers
from robocal.programs.model import Program, Target
from robocal.programs.track import MM

if TYPE_CHECKING:
    from robocal.programs.dialects.base import Dialect

UNNAMED = "?"  # a carried frame's unit the program does not name: "?" + what moves it (KRL EK root)


def coordinated_unit(program: Program, t: Target) -> str | None:
    """The mechanical unit whose plate carries target ``t``'s frame (None: a frame of the world)."""
    return program.carried.get(t.frame)


def needs_cell(unit: str) -> str:
    """Why a target coordinated with ``unit`` is not corrected without a cell model."""
    if unit.startswith(UNNAMED):
        return (f"coordinated with a unit the files do not name ({unit[1:]}): give a cell file (--model "
                "CELL.yaml) with its positioner (and the file naming the unit, e.g. $config.dat, with "
                "--references)")
    return f"coordinated with {unit}: give a cell file (--model CELL.yaml) whose positioner has unit {unit}"


def sort_external(program: Program, warnings: list[str], taken: frozenset[int] = frozenset(),
                  fixed_arm: bool = True, dialect: Dialect | None = None, fixed_base: bool = False,
                  not_arm: frozenset[str] = frozenset(), cell: bool = False) -> None:
    """Keep in ``program.targets`` the targets that can be corrected as arm targets (and those in
    ``taken``: ids a cell model already took, :mod:`robocal.programs.positioner`); name every
    other target with external values (a warning and its reason in ``program.not_corrected``,
    so each motion reaching it is named). Appends one warning counting the targets whose
    external values no work object follows. ``fixed_arm`` False (an arm on a track, whose
    targets the track took first): a target with other external values is named, the arm's
    place depending on them. ``dialect``: the program's (its :attr:`Dialect.arm_axes` and pose
    notation, for :func:`carried_arm`; None: no axis weighed); ``fixed_base``: the user declared that
    no external axis carries the arm; ``not_arm``: axes the cell file gives a positioner; ``cell``: a
    work cell was given (its arm on no track), so the warning does not ask for one."""
    carriers = {} if fixed_base or not fixed_arm or dialect is None else \
        carried_arm(program, dialect, taken, not_arm)
    kept, loose, letters = [], 0, set()
    for t in program.targets:
        unit = None if id(t) in taken else coordinated_unit(program, t)
        if unit is not None:
            why = needs_cell(unit)
        elif id(t) in taken or not t.external:
            kept.append(t)
            continue
        elif t.axes and fixed_arm and (axis := next((a for a, v in sorted(t.axes.items()) if a in carriers
                                                     and v != 0.0), None)):
            why = carriers[axis]  # an axis that carries the arm, or may: the arm's base moves with it
        elif t.axes and fixed_arm:  # values as data: read by the dialect, in a frame no unit carries
            kept.append(t)
            loose += 1
            letters |= {k for k, v in t.axes.items() if v != 0.0} or set(t.axes)
            continue
        else:
            why = (f"external axes {t.external}: the target moves with axes outside the arm (a track, gantry "
                   "or positioner) and the filter assumes a fixed base and work")
        program.not_corrected[id(t)] = why
        warnings.append(f"{t.where}: not corrected: {why}")
        program.uncorrected.append(f"{t.where}: not corrected: {why}")
    if loose:
        axes = ", ".join(sorted(letters))
        tail = ("; no external axis carries the arm (--fixed-base)" if fixed_base else "" if cell else
                "; if a track or gantry carries the arm, give its cell file (--model CELL.yaml)")
        warnings.append(f"{loose} target(s) carry external-axis values ({axes}) in work objects no "
                        "mechanical unit moves: corrected as arm targets (the values do not move them "
                        f"relative to the arm){tail}")
    program.targets = kept


def carried_arm(program: Program, dialect: Dialect, taken: frozenset[int] = frozenset(),
                not_arm: frozenset[str] = frozenset(), targets: list[Target] | None = None) -> dict[str, str]:
    """The axes (the dialect's :attr:`Dialect.arm_axes` but ``not_arm``) that carry or may carry the
    arm, each with why, judged from the targets (``targets``, default ``program.targets``) with
    values in frames no unit carries (:func:`robocal.programs.carrier.arm_carriers`; their
    positions in the fixed frame, mm; a target in a frame not known yet is no evidence). The one
    judgement: the offline correction (:func:`sort_external`) and the run-time one
    (:mod:`robocal.programs.routing`) both ask it."""
    loose = [t for t in (program.targets if targets is None else targets)
             if t.axes and id(t) not in taken and coordinated_unit(program, t) is None]
    names = sorted({a for t in loose for a in t.axes if a in dialect.arm_axes and a not in not_arm})
    if not names:
        return {}
    values = {a: np.array([t.axes.get(a, np.nan) for t in loose], float) for a in names}
    poses = dialect.to_pose(np.array([[float(n.text) for n in t.numbers] for t in loose], float))
    W = np.array([program.frames.get(t.frame, np.full((4, 4), np.nan)) for t in loose])
    return arm_carriers(values, (W @ poses)[:, :3, 3] / MM)


def unreached_reason(t: Target, why: str, fixed_arm: bool = True) -> str:
    """Why target ``t``, corrected as an arm target, was left unchanged (``why``: the arm's reason,
    out of reach or a configuration it cannot have): for a target whose external-axis values were
    read (:attr:`Target.axes`) in a frame no unit carries, on an arm assumed fixed, the reason adds
    the values: if they move the arm (a track or gantry, the controller's base moving with them),
    the fixed arm's answer says nothing of the program and the track's cell file is what to give."""
    if not (fixed_arm and t.axes and t.external):
        return why
    return (f"{why}; the target carries external-axis values ({t.external}): if those axes move the arm "
            "(a track or gantry carrying it), give the cell file (--model CELL.yaml) with that track")
