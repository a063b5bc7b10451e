"""Motion-level accounting: every motion instruction that reaches a Cartesian pose gets one record.

A dialect opens one :class:`Account` per motion instruction it reads (:meth:`Ledger.open`, keyed by
file and the instruction's offset, so opening it again returns the same account) and tells it,
for each Cartesian target the instruction reaches, either the :class:`~robocal.programs.model.Target`
(:meth:`Account.reach`, through :meth:`Program.use`) or why that part cannot be corrected
(:meth:`Account.name`, through :meth:`Program.skip`). A motion to joints only (MoveAbsJ, PTP of an
AXIS/E6AXIS, FANUC joint representation, ``movej([...])``) is not opened: it needs no correction.

After filtering, :meth:`Ledger.records` turns the accounts into :class:`MotionRecord` rows with
the status of each target (corrected, or the reason it was not): a motion is ``corrected`` when
every target it reaches was corrected and nothing in it was named; otherwise it is ``named`` with
the reasons. A target used by several motions is corrected once and every motion that uses it
counts. A motion that applies a corrected target differently (FANUC ``INC``, a run-time offset)
names that and is not counted as corrected. :func:`summary` gives ``{"total", "corrected",
"named"}`` and checks ``corrected + named == total``.

New dialects (INFORM, VAL3 ...) plug in by opening an account per motion instruction to a
Cartesian pose and calling, for each target it reaches::

    acc = prog.motion(src, at, "MOVL")                        # once per instruction
    prog.use(target, tool, frame, here, label, "user frame", (src.path, offset), acc)
    prog.skip(here, "MOVL", why, acc, label)                  # a part it cannot correct
    prog.skip(here, "MOVL", Undeclared(why, "C00012 in the .JBI"), acc, label)  # declared nowhere

A target the dialect itself leaves alone although motions reach it goes in
``prog.not_corrected[id(target)] = why``. The filter does the rest (statuses, summary, --strict).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from robocal.programs.source import ProgramText
from robocal.programs.target import Target

CORRECTED = "corrected"
NAMED = "named"
LABEL_CHARS = 60  # a motion's target as written, shortened to this in its record


class Undeclared(str):
    """A reason a motion is not corrected: a name declared in none of the files given. It reads as
    the reason; ``needs`` is the declaration the motion needs (``robtarget pService``), which
    ``filter_program(strict=True)`` refuses to go without."""

    needs: str

    def __new__(cls, why: str, needs: str) -> Undeclared:
        obj = super().__new__(cls, why)
        obj.needs = needs
        return obj


@dataclass(frozen=True, slots=True)
class MotionRecord:
    """One motion instruction: ``file`` (name), ``line`` (1-based), ``instruction`` as written,
    ``target`` (the target(s) it reaches, ', '-joined, or the expression written), ``status``
    (:data:`CORRECTED` or :data:`NAMED`), ``reason`` ('' when corrected) and ``needs`` (the
    declaration(s) it needs that no file given holds, '; '-joined, else '')."""

    file: str
    line: int
    instruction: str
    target: str
    status: str
    reason: str = ""
    needs: str = ""

    def as_dict(self) -> dict:
        """The record's fields by name (all scalars: no deep copy as in dataclasses.asdict)."""
        return {name: getattr(self, name) for name in self.__slots__}


@dataclass
class Account:
    """What one motion instruction reaches: ``targets`` (corrected if filtered), ``labels`` (the
    names of what it moves to, for the record) and ``named`` (reasons a part of it is not
    corrected)."""

    source: ProgramText
    at: int
    instruction: str
    targets: list[Target] = field(default_factory=list)
    labels: list[str] = field(default_factory=list)
    named: list[str] = field(default_factory=list)
    needs: list[str] = field(default_factory=list)

    @property
    def where(self) -> str:
        return self.source.where(self.at)

    def reach(self, target: Target, label: str | None = None) -> None:
        """The motion reaches ``target`` (a target reached twice counts once)."""
        if all(t is not target for t in self.targets):
            self.targets.append(target)
            self.mention(label or target.name)

    def name(self, why: str, label: str = "") -> None:
        """A part of the motion is not corrected, because ``why`` (``label``: what it moves to)."""
        if why not in self.named:
            self.named.append(why)
        if isinstance(why, Undeclared) and why.needs not in self.needs:
            self.needs.append(why.needs)
        if label:
            self.mention(label)

    def mention(self, label: str) -> None:
        """Name what the motion moves to in its record (a target, or the expression written)."""
        label = " ".join(label.split())
        label = label if len(label) <= LABEL_CHARS else label[:LABEL_CHARS - 3] + "..."
        if label and label not in self.labels:
            self.labels.append(label)


class Ledger:
    """The accounts of a program's motion instructions, in the order they were opened."""

    def __init__(self) -> None:
        self._accounts: dict[tuple[Path, int], Account] = {}

    def open(self, source: ProgramText, at: int, instruction: str) -> Account:
        """The account of the motion instruction ``instruction`` at offset ``at`` of ``source``."""
        key = (source.path, at)
        acc = self._accounts.get(key)
        if acc is None:
            acc = self._accounts[key] = Account(source, at, instruction)
        return acc

    def __len__(self) -> int:
        return len(self._accounts)

    def __iter__(self):
        return iter(self._accounts.values())

    def records(self, corrected: set[int], reasons: dict[int, str]) -> list[MotionRecord]:
        """One record per motion, sorted by file (in the order files were opened) and offset.
        ``corrected``: ``id(target)`` of the targets that were corrected; ``reasons``: ``id(target)``
        -> why, for targets left alone. An account that reaches no target and names nothing is a
        motion to joints only (a KRL name that resolves to an AXIS position): it has no record."""
        files: dict[Path, int] = {}
        for acc in self._accounts.values():
            files.setdefault(acc.source.path, len(files))
        out = []
        for acc in sorted(self._accounts.values(), key=lambda a: (files[a.source.path], a.at)):
            if not acc.targets and not acc.named:
                continue
            why = list(acc.named)
            for t in acc.targets:
                if id(t) not in corrected:
                    reason = reasons.get(id(t), "not corrected")
                    why.append(reason if t.name in reason else f"{t.name}: {reason}")
            why = list(dict.fromkeys(why))
            out.append(MotionRecord(acc.source.path.name, acc.source.line_of(acc.at), acc.instruction,
                                    ", ".join(acc.labels), NAMED if why else CORRECTED, "; ".join(why),
                                    "; ".join(acc.needs)))
        return out


def undeclared(ledger: Ledger) -> list[str]:
    """``file:line (INSTRUCTION): needs DECLARATION`` for each motion that needs a declaration no
    file given holds."""
    return [f"{acc.where} ({acc.instruction}): needs {'; '.join(acc.needs)}" for acc in ledger if acc.needs]


def summary(records: list[MotionRecord]) -> dict[str, int]:
    """``{"total": N, "corrected": K, "named": U}``; every motion is one or the other."""
    corrected = sum(r.status == CORRECTED for r in records)
    named = sum(r.status == NAMED for r in records)
    if corrected + named != len(records):
        raise AssertionError(f"motion accounting: {corrected} corrected + {named} named != {len(records)}")
    return {"total": len(records), "corrected": corrected, "named": named}


def summary_line(counts: dict[str, int]) -> str:
    """The CLI's line: ``N motions: K corrected, U not corrected (each named)``."""
    return (f"{counts['total']} motions: {counts['corrected']} corrected, {counts['named']} not corrected "
            "(each named)")
