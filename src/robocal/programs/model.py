"""What every program format gives the filter: a :class:`Program`, its Cartesian targets with the
spans to rewrite.

A :class:`~robocal.programs.target.Target` is one Cartesian position of a program (a declaration
or a literal written in a motion instruction): the numbers of its pose in the file's units, the
frame (work object, base, user frame, feature) and the tool it is used with, and its
configuration data. A :class:`~robocal.programs.dialects.base.Dialect` knows one language's
notation and reads its files into a :class:`Program`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.programs.motions import Account, Ledger
from robocal.programs.source import ProgramText
from robocal.programs.target import IDENTITY, Target

__all__ = ["IDENTITY", "Program", "Target"]


@dataclass
class Program:
    """Parsed program files: targets in execution order, named frames and tools (4x4, m, in the
    robot's base frame / on the flange), warnings about what was left alone, and joint targets
    ``(index of the next Cartesian target, joints rad)`` for dialects without configuration, and
    tools / frames whose targets cannot be filtered (a stationary tool, a moving frame).
    ``motions``: each motion's target or joints ``(file, offset, Target | joints)`` in text order;
    ``sequence``: the same in execution order, every execution (a routine called twice runs its
    motions twice), with the call that entered its routine (``file:line``, '' at the entry).
    ``ledger``: one :class:`~robocal.programs.motions.Account` per motion instruction to a Cartesian
    pose (:meth:`motion`); ``not_corrected``: ``id(target)`` -> why, for targets a dialect leaves
    alone although a motion reaches them (a FANUC position used only as an INC displacement).
    ``executed``: the text pieces ``(file, start, end)`` in the order the controller runs them
    (:mod:`robocal.programs.flow`; empty: not known, text order). ``declared_tools``: the tool data
    the program holds without the user's ``tools`` (what the files declare and the controller's
    own, e.g. tool0 or the flange), name -> 4x4 (m): what a ``--tool`` of the same name replaces;
    ``declared_frames`` likewise the frames it holds without the user's ``frames`` (in the robot's
    base frame): what a ``--frame`` replaces (both compared by :mod:`robocal.programs.overrides`).
    ``carried``: frames that a mechanical unit moves (a work object on a positioner's plate: RAPID
    ufmec, KRL external kinematics, an INFORM station frame, FANUC coordinated motion), frame name ->
    the unit's name as the program and the cell file call it (``STN1``); such a frame is in that
    unit's plate frame, not the robot's world (:mod:`robocal.programs.positioner`). ``in_world``:
    the carried frames whose targets are written in the robot's world as taught with the unit at
    their values (an INFORM station-coordinated position): on the plate such a target is
    ``inv(plate(e)) @ W @ T``. ``runtime_sites``: the target arguments of motions whose target is
    computed at run time (:class:`robocal.programs.runtime.RuntimeSite`), for ``--runtime-correction``."""

    targets: list[Target]
    frames: dict[str, np.ndarray] = field(default_factory=dict)
    tools: dict[str, np.ndarray] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    joint_targets: list[tuple[int, np.ndarray]] = field(default_factory=list)
    unsupported: dict[str, str] = field(default_factory=dict)  # 'tool:NAME' / 'frame:NAME' -> why
    uncorrected: list[str] = field(default_factory=list)  # motions left as they are, each also a warning
    used: dict[int, tuple[str, str, str]] = field(default_factory=dict)  # id(target) -> tool, frame, where
    motions: list[tuple[Path, int, Target | np.ndarray]] = field(default_factory=list)
    sequence: list[tuple[Target | np.ndarray, str]] = field(default_factory=list)
    ledger: Ledger = field(default_factory=Ledger)
    not_corrected: dict[int, str] = field(default_factory=dict)
    executed: list[tuple[Path, int, int]] = field(default_factory=list)  # text pieces in execution order
    declared_tools: dict[str, np.ndarray] = field(default_factory=dict)
    declared_frames: dict[str, np.ndarray] = field(default_factory=dict)
    carried: dict[str, str] = field(default_factory=dict)  # frame name -> mechanical unit moving it
    in_world: set[str] = field(default_factory=set)  # carried frames whose targets are taught in the world
    runtime_sites: list = field(default_factory=list)  # target arguments computed at run time
    _seen: tuple[set[str], int] = field(default_factory=lambda: (set(), 0), repr=False)  # `uncorrected`'s
    # lines and how many of them the set holds

    def motion(self, source: ProgramText, at: int, instruction: str) -> Account:
        """The account of the motion instruction at offset ``at`` of ``source`` (opened once)."""
        return self.ledger.open(source, at, instruction)

    def use(self, t: Target, tool: str, frame: str, here: str, label: str, frame_word: str,
            motion: tuple[Path, int], account: Account | None = None) -> bool:
        """A motion at ``here`` (``motion``: its file and offset) reaches target ``t`` with ``tool`` in
        ``frame``: the first use appends it to :attr:`targets` (True); a later use with the same
        tool and frame adds nothing (False); one with another tool or frame leaves the target
        uncorrected, every motion to it named (one corrected target cannot serve both: a valid
        program, e.g. a search pattern taught once and run in two work objects, is not refused).
        Every use is a step of :attr:`motions`. ``label``
        names the target and ``frame_word`` its kind of frame in the message. ``account``: the
        motion instruction's account, which the target joins."""
        self.motions.append((*motion, t))
        if account is not None:
            account.reach(t)
        if id(t) in self.used:
            tool0, frame0, at0 = self.used[id(t)]
            if (tool0, frame0) != (tool, frame) and id(t) not in self.not_corrected:
                why = (f"{label} is used with tool {tool} and {frame_word} {frame} at {here}, with tool "
                       f"{tool0} and {frame_word} {frame0} at {at0}: one corrected target cannot serve both "
                       "(every motion to it is named); declare a copy for each use")
                self.not_corrected[id(t)] = why
                self.warnings.append(f"{t.where}: not corrected: {why}")
                self.uncorrected.append(f"{t.where}: not corrected: {why}")
                self.targets = [u for u in self.targets if u is not t]
            return False
        self.used[id(t)] = (tool, frame, here)
        t.tool, t.frame, t.order = tool, frame, len(self.targets)
        self.targets.append(t)
        return True

    def withhold(self, t: Target, why: str) -> None:
        """Target ``t`` is also moved to with a tool or frame known only at run time (``why``): it is
        corrected for no use (its corrected numbers would move that motion too), every motion to
        it named; a later :meth:`use` adds it to no list."""
        if id(t) not in self.not_corrected:
            self.not_corrected[id(t)] = why
            self.warnings.append(f"{t.where}: not corrected: {why}")
            self.uncorrected.append(f"{t.where}: not corrected: {why}")
        self.targets = [u for u in self.targets if u is not t]
        self.used.setdefault(id(t), ("", "", ""))

    def skip(self, where: str, instruction: str, why: str, account: Account | None = None,
             label: str = "") -> None:
        """Account for a motion to a Cartesian pose this filter cannot correct: a warning naming
        ``where`` (file:line), the instruction and why; ``account``: the motion instruction's account
        (None: a call of a routine not in these files, which may move there), ``label``: what the
        motion moves to as written."""
        if account is not None:
            account.name(why, label)
        text = f"{where}: {instruction}: not corrected: {why}"
        seen, synced = self._seen
        seen.update(self.uncorrected[synced:])  # lines appended elsewhere (the list only grows)
        if text not in seen:  # a set: a list's `in` made 100,000 named motions quadratic
            seen.add(text)
            self.uncorrected.append(text)
            self.warnings.append(text)
        self._seen = (seen, len(self.uncorrected))
