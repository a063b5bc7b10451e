"""The order in which a controller runs a program's motions, derived statically from its routines.

A controller without configuration data (URScript, a RAPID/KRL target without them or with
ConfL\\Off) takes per target the IK solution nearest the joints it comes from, so the previous
motion must be the one executed before, not the one written before. From the program's entry
(URScript: the top-level statements, else the one top-level ``def`` nothing calls; RAPID: PROC
main; KRL: the DEF named like its .src file) the statements are walked in text order, and a call
of a routine of these files walks that routine's body there (inline expansion, to any depth; a
routine already on the call stack is not entered again, with a warning naming the cycle; loops and
branches are taken once, in text order). A motion inside a routine called several times is
executed several times: each execution is a step of :attr:`Program.sequence`, tagged with the call
that brought control into its routine.
Motions the walk never reaches (routines no call reaches) follow in text order.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from pathlib import Path

from robocal.programs.language_help import ENTRY_ROUTINES
from robocal.programs.model import Program, Target
from robocal.programs.source import ProgramText

MAX_SEGMENTS = 100_000  # inline expansion larger than this (deeply nested calls): text order is kept


@dataclass(frozen=True)
class Routine:
    """A routine: its file and the ``start:end`` offsets of its text (header to end)."""

    name: str
    source: ProgramText
    start: int
    end: int

    @property
    def path(self) -> Path:
        return self.source.path


@dataclass
class Flow:
    """A program's routines (name as the dialect compares them -> body), the calls of routines of
    these files ``(file, offset, name)``, and its entry (a routine, or the top-level code of a
    file as a Routine spanning the file; None: not found)."""

    routines: dict[str, Routine] = field(default_factory=dict)
    calls: list[tuple[ProgramText, int, str]] = field(default_factory=list)
    entry: Routine | None = None


def _segments(flow: Flow, cycles: list[str]) -> list[tuple[Path, int, int, str]] | None:
    """The executed text pieces ``(file, start, end, via)`` in execution order (``via``: the call
    that entered the piece's routine, '' for the entry), None when larger than MAX_SEGMENTS. Walked
    with an explicit stack (no recursion limit on the depth of call chains); each recursive call
    (a routine already being walked) is appended to ``cycles`` as a warning naming the cycle."""
    calls: dict[Path, list[tuple[int, str]]] = {}
    for src, at, name in flow.calls:
        if name in flow.routines:
            calls.setdefault(src.path, []).append((at, name))
    for v in calls.values():
        v.sort()
    bodies = list(flow.routines.values())
    out: list[tuple[Path, int, int, str]] = []

    def emit(path: Path, a: int, b: int, nested: list[Routine], via: str) -> None:
        for r in nested:  # a routine declared inside this one is not executed where it is written
            if r.start >= b or r.end <= a:
                continue
            if r.start > a:
                out.append((path, a, r.start, via))
            a = max(a, r.end)
        if a < b:
            out.append((path, a, b, via))

    def pieces(r: Routine) -> list:
        """The routine's own text pieces between calls, and its calls: ``('text', a, b)`` and
        ``('call', at, name)`` in text order."""
        nested = sorted((x for x in bodies if x.path == r.path and r.start <= x.start and x.end <= r.end
                         and x is not r), key=lambda x: x.start)
        here = calls.get(r.path, [])
        out_, pos = [], r.start
        for at, name in here[bisect.bisect_left(here, (r.start, "")):]:
            if at >= r.end:
                break
            if any(x.start <= at < x.end for x in nested):
                continue
            out_ += [("text", pos, at, nested), ("call", at, name)]
            pos = at
        return [*out_, ("text", pos, r.end, nested)]

    # an explicit stack instead of recursion: call chains of any depth (one frame per routine entered)
    entry = flow.entry
    assert entry is not None
    frames = [(entry, iter(pieces(entry)), "")]
    active = {entry.name}
    while frames:
        r, items, via = frames[-1]
        item = next(items, None)
        if item is None:
            frames.pop()
            active.discard(r.name)
            continue
        if item[0] == "text":
            emit(r.path, item[1], item[2], item[3], via)
            if len(out) > MAX_SEGMENTS:
                return None
        elif item[2] in active:  # a routine already being walked is not entered again
            where = f"{r.path.name}:{r.source.line_of(item[1])}"
            chain = [f[0].name for f in frames]
            cycle = " -> ".join([*chain[chain.index(item[2]):], item[2]])
            text = f"{where}: a recursive call ({cycle}): its motions are ordered from the first entry only"
            if text not in cycles:
                cycles.append(text)
        else:
            callee = flow.routines[item[2]]
            active.add(callee.name)
            frames.append((callee, iter(pieces(callee)), f"{r.path.name}:{r.source.line_of(item[1])}"))
    return out


def _executed(steps: list, segments: list) -> list[tuple[int, str]]:
    """``(index into steps, via)`` of every step executed by ``segments``, in execution order; a
    motion reaching several targets through routine parameters counts at its first execution only
    (which call passes which target is not tracked)."""
    by_path: dict[Path, list[tuple[int, int]]] = {}
    several: dict[tuple[Path, int], int] = {}  # a motion -> how many targets it reaches
    for k, (path, at, _) in enumerate(steps):
        by_path.setdefault(path, []).append((at, k))
        several[(path, at)] = several.get((path, at), 0) + 1
    for v in by_path.values():
        v.sort()
    out, seen = [], set()
    for path, a, b, via in segments:
        here = by_path.get(path, [])
        for _, k in here[bisect.bisect_left(here, (a, -1)):bisect.bisect_left(here, (b, -1))]:
            if several[steps[k][:2]] == 1 or k not in seen:
                out.append((k, via))
                seen.add(k)
    return out


def order_by_execution(prog: Program, flow: Flow) -> None:
    """Put ``prog``'s motions (:attr:`Program.motions`, in text order) in execution order: fill
    :attr:`Program.sequence` (every execution), order :attr:`Program.targets` by first execution
    and rebuild :attr:`Program.joint_targets`. Without an entry, text order is kept (a warning when
    routines exist)."""
    steps = prog.motions
    order: list[tuple[int, str]] = []  # (index into steps, via) in execution order
    why = ""
    if flow.entry is None:
        why = f"no entry routine found ({ENTRY_ROUTINES})" if flow.routines else ""
    else:
        cycles: list[str] = []
        segments = _segments(flow, cycles)
        prog.warnings += cycles
        if segments is None:
            why = f"the routine calls expand to more than {MAX_SEGMENTS} pieces"
        else:
            order = _executed(steps, segments)
            prog.executed = [(path, a, b) for path, a, b, _ in segments]
    if why:
        prog.warnings.append(f"{why}: targets are chained in text order, which may differ from the order the "
                             "controller runs them in (the solution nearest the previous joints may differ)")
    reached = {k for k, _ in order}
    order += [(k, "") for k in range(len(steps)) if k not in reached]
    prog.sequence = [(steps[k][2], via) for k, via in order]
    first: dict[int, int] = {}
    kept = {id(t) for t in prog.targets}
    prog.joint_targets = []
    for item, _ in prog.sequence:
        if isinstance(item, Target):
            if id(item) in kept:
                first.setdefault(id(item), len(first))
        elif not prog.joint_targets or prog.joint_targets[-1][0] != len(first):
            prog.joint_targets.append((len(first), item))
        else:
            prog.joint_targets[-1] = (len(first), item)
    for t in prog.targets:
        t.order = first.get(id(t), len(first) + t.order)
    prog.targets.sort(key=lambda t: t.order)
