"""What every dialect's load reader shares: the load (kg, centre of mass in tool0), the
statement that sets it, the reader interface and its errors (the dialects: the package docstring)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from robocal.core.errors import DataError
from robocal.programs.source import NUMBER_RE, ProgramText
from robocal.programs.target import Target

MM, CM = 1e-3, 1e-2  # m
STATEMENT_CHARS = 60  # a load statement quoted in messages is shortened to this
NUM = f"({NUMBER_RE.pattern})"
ADVICE = "give the load with --payload KG[,X,Y,Z] (every motion) instead"

Load = tuple[float, float, float, float]  # kg, then the centre of mass x, y, z (m) in tool0


@dataclass(frozen=True)
class Setting:
    """A statement that sets the load, at offset ``at`` of ``path`` (``where``: file:line and the
    statement). ``mass`` kg and ``cog`` (3,) m replace the current ones; None keeps them (URScript's
    partial setters). ``grip``: a RAPID payload (GripLoad), added to the tool's load, its ``cog``
    in the tool frame."""

    path: Path
    at: int
    where: str
    mass: float | None = None
    cog: tuple[float, float, float] | None = None
    grip: bool = False


def setting(src: ProgramText, at: int, text: str, mass, cog, grip: bool = False) -> Setting:
    """The :class:`Setting` of statement ``text`` at offset ``at`` of ``src`` (mass kg, cog m)."""
    text = " ".join(text.split())
    text = text if len(text) <= STATEMENT_CHARS else text[:STATEMENT_CHARS - 3] + "..."
    where = f"{src.path.name}:{src.line_of(at)} ({text})"
    return Setting(src.path, at, where, None if mass is None else float(mass),
                   None if cog is None else tuple(float(c) for c in cog), grip)


def unread(src: ProgramText, at: int, text: str, why: str) -> DataError:
    """The error for a load statement that cannot be read: where, the statement, why, the advice."""
    return DataError(f"{src.path.name}:{src.line_of(at)}: {' '.join(text.split())[:STATEMENT_CHARS]}: {why}; "
                     f"{ADVICE}")


class LoadReader:
    """One dialect's load statements: :meth:`settings` in the program files, :meth:`at_motion` the
    load a motion runs with given the last settings executed before it. ``none``: why a motion
    runs with the model's default load (for the summary); ``hint``: where the user gives the load
    instead of ``--payload`` ('' for a dialect with no load data)."""

    none = "the program sets none before these motions"
    hint = "load data in the program before these motions"

    def settings(self, sources: list[ProgramText], references: list[ProgramText]) -> list[Setting]:
        """Every statement of ``sources`` that sets the load, in text order per file."""
        return []

    def at_motion(self, state: dict, target: Target, instruction: tuple[ProgramText, int] | None) \
            -> tuple[Load, str] | None:
        """``(load, where it was set)`` of a motion to ``target`` after the settings in ``state``
        (``'load'``/``'grip'`` -> the last :class:`Setting` merged; absent: none executed);
        ``instruction``: the motion instruction's file and offset. None: the program sets none."""
        last = state.get("load")
        if last is None or last.mass is None:
            return None
        return (last.mass, *(last.cog or (0.0, 0.0, 0.0))), last.where


def ranges(values: list[int]) -> str:
    """``3-5, 9``: sorted distinct integers as runs."""
    parts, start = [], values[0]
    for a, b in zip(values, [*values[1:], None], strict=True):
        if b != a + 1:
            parts.append(f"{start}" if start == a else f"{start}-{a}")
            start = b
    return ", ".join(parts)
