"""The load each motion of a program runs with, and each target corrected with it.

For a model with a payload term, every motion is corrected with the load active where the
controller runs it: the statements that set the load (:mod:`robocal.programs.load_data`, per
dialect) and the motions are walked in execution order (:attr:`Program.executed`, the routines'
text pieces as :mod:`robocal.programs.flow` walks them; dialects without one, and motions the walk
never reaches, in text order, file after file), and each motion takes the load of the last
statement before it (RAPID: its tool's load plus the GripLoad payload, or its ``\\TLoad``; KRL:
its own ``WITH $LOAD``). A motion before any statement runs with whatever load the controller
had: the model's default (no payload), with the warning naming it.

A target is corrected once, for the load of its first execution. A motion reaching it with
another load (a routine called with two loads, one position taught for the empty and the loaded
gripper) is named in the motion accounting: its target is not corrected for the load it runs
with. ``payload`` given (``--payload``) runs every motion with it; a model without a payload term
reads no load data.

The targets are compensated per load (:func:`compensate_by_load`): one model per distinct load,
each target with its own, the results put back in the targets' order.
"""

from __future__ import annotations

import bisect
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.deploy.compensation import Compensation, check_masses
from robocal.ik.singularity import SingularityDistance
from robocal.kinematics.joint_errors import condition_terms, condition_warnings
from robocal.kinematics.model import Robot
from robocal.programs.dialects.base import Dialect
from robocal.programs.load_data import Load, LoadReader, Setting
from robocal.programs.load_data.base import ranges
from robocal.programs.model import Program, Target
from robocal.programs.motions import Account
from robocal.programs.registry import capable
from robocal.programs.source import ProgramText

SAME_LOAD = 1e-9  # kg and m: two loads closer than this in every number are the same load
NO_LOAD = "no load set by the program before it"
PAYLOAD_OPTION, TEMPERATURE_OPTION = "--payload KG[,X,Y,Z]", "--temperature C"


@dataclass
class LoadPlan:
    """``keys``: per target (the filter's order) the load it is corrected with (kg, x, y, z m in
    tool0), None for the model's default; ``lines``: which motions run with which load, for the
    summary; ``warnings``: the motions named because their target is corrected for another load;
    ``hint``: where the dialect's programs give their load (besides ``--payload``), for the
    warning about a default load."""

    keys: list[Load | None]
    lines: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    hint: str = LoadReader.hint

    def groups(self) -> list[tuple[Load | None, np.ndarray]]:
        """``(load, indices of its targets)`` per distinct load, in the order first used."""
        order: dict[Load | None, list[int]] = {}
        for i, k in enumerate(self.keys):
            order.setdefault(k, []).append(i)
        return [(k, np.array(v, dtype=int)) for k, v in order.items()]


def _capable(attribute: str) -> str:
    """``attribute`` (vendor, schedule_statement) of the languages whose loads come from payload
    schedules."""
    return " / ".join(getattr(d, attribute) for d in capable("payload_schedules"))


def plan_loads(dialect: Dialect, program: Program, targets: list[Target], calibrated: Robot,
               sources: list[ProgramText], references: list[ProgramText], payload=None,
               schedules: str | Path | dict[int, Load] | None = None,
               nominal: Robot | None = None) -> LoadPlan:
    """The load of each of ``targets`` (module docstring). ``payload``: kg or (kg, x, y, z m),
    overriding the program's; ``schedules``: payload schedules (of a language that
    has them, :meth:`~robocal.programs.dialects.base.Dialect.read_schedules`), a file or
    schedule -> (kg, x, y, z m); their masses checked against the rated payload of ``calibrated``, else
    of ``nominal`` (`robocal.deploy.compensation.check_masses`, as ``payload``'s).
    Motions named for running with another load than their target's are named in ``program``'s
    accounting (its ledger and uncorrected)."""
    if schedules is not None and not dialect.payload_schedules:
        raise DataError(f"--payload-schedules is for {_capable('vendor')} programs "
                        f"({_capable('schedule_statement')}), not {dialect.name}")
    if isinstance(schedules, str | Path):
        schedules = dialect.read_schedules(schedules)
    elif schedules is not None:
        schedules = {int(k): tuple(np.asarray(v, float).tolist()) for k, v in schedules.items()}
    if schedules:  # masses in lb or g: against the model's rated payload
        check_masses([load[0] for load in schedules.values()], calibrated, nominal, "--payload-schedules")
    if "payload" not in condition_terms(calibrated):  # --payload given anyway: the CLI says it is not used
        unused = [] if schedules is None else [f"--payload-schedules is not used: the model of "
                                               f"{calibrated.name} has no payload term"]
        return LoadPlan([None] * len(targets), warnings=unused)
    if payload is not None:
        key = _key(calibrated.with_conditions(payload).joint_errors.payload)  # checked: kg >= 0, 1 or 4
        return LoadPlan([key] * len(targets), [f"{_text(key)} (--payload): every motion"])
    reader = dialect.load_reader(program.tools, schedules)
    settings = reader.settings(sources, references)
    index = {id(t): i for i, t in enumerate(targets)}
    runs = _executions(program, settings, index)
    finder = _AccountFinder(program)
    first: dict[int, tuple[Load | None, str]] = {}  # target index -> its first execution's load
    motions: dict[int, tuple[Account | None, Load | None, str]] = {}  # id(account) -> first load
    plan = LoadPlan([None] * len(targets), hint=reader.hint)
    keys: dict[tuple, Load] = {}  # a load as read -> its key (a few distinct loads, many motions)
    for state, path, offset, i in runs:
        acc = finder.find(path, offset)
        got = reader.at_motion(state, targets[i], (acc.source, acc.at) if acc else None)
        if got is not None and got[0] not in keys:
            keys[got[0]] = _key(got[0])
        key, where = (None, NO_LOAD) if got is None else (keys[got[0]], got[1])
        motions.setdefault(id(acc), (acc, key, where))
        if i not in first:
            first[i] = (key, where)
            plan.keys[i] = key
        elif first[i][0] != key and acc is not None:
            t = targets[i]
            why = (f"its target {t.name} is corrected for the load of its first execution "
                   f"({_text(first[i][0])}, {first[i][1]}) but this motion runs with {_text(key)} ({where}): "
                   "declare a copy of the target for each load")
            if why not in acc.named:
                acc.name(why)
                text = f"{acc.where}: {acc.instruction}: not corrected: {why}"
                program.uncorrected.append(text)
                plan.warnings.append(text)
    plan.lines = _lines([m for m in motions.values() if m[0] is not None], reader.none)
    return plan


def _executions(program: Program, settings: list[Setting], index: dict[int, int]) \
        -> list[tuple[dict, object, int, int]]:
    """``(state, file, offset, target index)`` of every execution of a motion to one of the
    targets, in execution order, ``state`` the load settings executed before it
    (:meth:`robocal.programs.load_data.LoadReader.at_motion`)."""
    events: dict = {}  # file -> sorted [(offset, kind, item)]: kind 0 a setting, 1 a motion
    for s in settings:
        events.setdefault(s.path, []).append((s.at, 0, s))
    uses = [(path, offset, t) for path, offset, t in program.motions if isinstance(t, Target)]
    seen = {id(t) for *_, t in uses}
    uses += [(acc.source.path, acc.at, t) for acc in program.ledger for t in acc.targets
             if id(t) not in seen]  # targets a dialect reaches without Program.use (FANUC P[n])
    for k, (path, offset, t) in enumerate(uses):
        if id(t) in index:
            events.setdefault(path, []).append((offset, 1, k))
    for v in events.values():
        v.sort(key=lambda e: (e[0], e[1]))
    out, reached, state = [], set(), {}

    def run(items) -> None:
        for _, kind, item in items:
            if kind == 0:
                _apply(state, item)
            else:
                path, offset, t = uses[item]
                out.append((dict(state), path, offset, index[id(t)]))
                reached.add(item)

    for path, a, b in program.executed:
        here = events.get(path, [])
        run(here[bisect.bisect_left(here, (a, -1)):bisect.bisect_left(here, (b, -1))])
    if len(reached) < sum(kind == 1 for v in events.values() for _, kind, _ in v):
        state = {}  # the motions the walk never reaches: in text order, file after file
        done = set(reached)
        for v in events.values():
            run([e for e in v if e[1] == 0 or e[2] not in done])
    return out


def _apply(state: dict, s: Setting) -> None:
    """Execute load setting ``s`` on ``state`` (``'load'`` / ``'grip'`` -> a merged Setting)."""
    if s.grip:
        state["grip"] = s
        return
    prev = state.get("load")
    mass = s.mass if s.mass is not None else (prev.mass if prev else None)
    cog = s.cog if s.cog is not None else (prev.cog if prev else None)
    state["load"] = replace(s, mass=mass, cog=cog)


class _AccountFinder:
    """The motion instruction (its account) a use of a target at ``(file, offset)`` belongs to:
    on the use's line the last instruction starting at or before it (else the first on the line),
    elsewhere the last one before it (a statement over several lines)."""

    def __init__(self, program: Program):
        self.by_path: dict = {}
        for acc in program.ledger:
            self.by_path.setdefault(acc.source.path, []).append((acc.at, acc))
        for v in self.by_path.values():
            v.sort(key=lambda e: e[0])
        self.starts = {path: [a for a, _ in v] for path, v in self.by_path.items()}
        self.last: tuple = (None, [], [])  # (path, its accounts, their starts): a Path hashes slowly

    def find(self, path, offset: int) -> Account | None:
        if path is not self.last[0]:
            self.last = (path, self.by_path.get(path, []), self.starts.get(path, []))
        _, accs, starts = self.last
        if not accs:
            return None
        k = bisect.bisect_right(starts, offset) - 1
        src = accs[0][1].source
        line = src.line_of(offset)
        later_here = k + 1 < len(accs) and src.line_of(accs[k + 1][0]) == line
        if later_here and (k < 0 or src.line_of(accs[k][0]) != line):
            return accs[k + 1][1]
        return accs[k][1] if k >= 0 else None


def _key(load) -> Load:
    """The load as a hashable key, rounded to SAME_LOAD (plain floats: called once per motion)."""
    return tuple(round(float(v) / SAME_LOAD) * SAME_LOAD + 0.0 for v in load)


def _text(key: Load | None) -> str:
    """``12 kg, centre of mass [0, 0, 300] mm`` (or the default)."""
    if key is None:
        return "the model's default (no payload)"
    cog = ", ".join(f"{c * 1e3:.4g}" for c in key[1:])
    return f"{key[0]:g} kg, centre of mass [{cog}] mm"


def _lines(motions: list[tuple[Account, Load | None, str]], none: str) -> list[str]:
    """One line per distinct load: the load, where it is set and the motions (file: lines);
    ``none``: why motions run with the model's default."""
    out: dict[Load | None, tuple[str, dict[str, list[int]]]] = {}
    for acc, key, where in motions:
        entry = out.setdefault(key, (where, {}))
        entry[1].setdefault(acc.source.path.name, []).append(acc.source.line_of(acc.at))
    lines = []
    for key, (where, files) in out.items():
        n = sum(len(v) for v in files.values())
        at = "; ".join(f"{name} {_ranges(sorted(set(v)))}" for name, v in files.items())
        what = f"{_text(key)} ({where})" if key is not None else \
            f"no load ({none}; the model's default, no payload)"
        lines.append(f"{what}: {n} motion(s), {at}")
    return lines


def _ranges(lines: list[int]) -> str:
    """``line 3`` / ``lines 3-5, 9``."""
    return ("line " if len(lines) == 1 else "lines ") + ranges(lines)


def compensate_by_load(plan: LoadPlan, model: Robot, temperature: float | None,
                       run: Callable[[Robot, np.ndarray], Compensation]) -> Compensation:
    """``run(model at one load and ``temperature``, indices of its targets)`` for each load of
    ``plan``, the results put back in the targets' order (one load: its result as is)."""
    models = [(idx, model.with_conditions(load, temperature)) for load, idx in plan.groups()]
    parts = [(idx, run(m, idx)) for idx, m in models]
    hints = (f"{plan.hint}, or {PAYLOAD_OPTION}" if plan.hint else PAYLOAD_OPTION, TEMPERATURE_OPTION)
    assumed = tuple(dict.fromkeys(a for _, m in models for a in condition_warnings(m, hints)))
    if len(parts) == 1:
        return replace(parts[0][1], assumed=assumed)
    N = len(plan.keys)

    def scatter(values: list[np.ndarray]) -> np.ndarray:
        out = np.empty((N, *values[0].shape[1:]), dtype=values[0].dtype)
        for (idx, _), v in zip(parts, values, strict=True):
            out[idx] = v
        return out

    comps = [c for _, c in parts]
    sing = None if comps[0].singularity is None else SingularityDistance(
        *(scatter([getattr(c.singularity, f.name) for c in comps]) for f in fields(SingularityDistance)))
    return replace(comps[0], joints=scatter([c.joints for c in comps]),
                   corrected_targets=scatter([c.corrected_targets for c in comps]),
                   converged=scatter([c.converged for c in comps]),
                   position_error=scatter([c.position_error for c in comps]),
                   orientation_error=scatter([c.orientation_error for c in comps]), singularity=sing,
                   controller=None, assumed=assumed)


__all__ = ["LoadPlan", "compensate_by_load", "plan_loads"]
