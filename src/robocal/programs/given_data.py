"""What the user gives the filter beside the program files, checked: ``--tool`` / ``--frame`` /
``--robot-base`` values whose magnitudes say another unit than the language's notation, a payload
or temperature the model has no term for, and files that read as another language than their
suffix says (:func:`robocal.programs.filter_program`); values that differ from the program's own
data: :mod:`robocal.programs.overrides`."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.core.magnitudes import (
    LENGTH_SCALES_M,
    check_degrees,
    check_frame,
    check_radians,
    check_tool,
)
from robocal.kinematics.joint_errors import condition_terms
from robocal.kinematics.model import Robot
from robocal.programs.dialects.base import Dialect
from robocal.programs.registry import DIALECTS, dialect_named, dialects, language_of


def _language(given: list[Path], dialect: str | None) -> Dialect | None:
    """The language named ``dialect``, else the one the first file's suffix names (None: none)."""
    if dialect is not None:
        return dialect_named(dialect) if dialect in DIALECTS else None
    return language_of(given[0]) if given else None


def check_magnitudes(given: list[Path], dialect: str | None, tools, frames, reach_m: float) -> None:
    """Refuse ``tools`` / ``frames`` text values whose magnitudes say another unit than the
    language's notation (its ``length_unit`` and ``angle_unit``) for a robot of ``reach_m``
    (:mod:`robocal.core.magnitudes`); 4x4 values and malformed text (the reader names it) pass."""
    language = _language(given, dialect)
    unit = "mm" if language is None else language.length_unit
    angles = None if language is None else language.angle_unit
    for option, named in (("--tool", tools), ("--frame", frames)):
        for name, text in (named or {}).items():
            if not isinstance(text, str):
                continue
            try:
                values = [float(v) for v in text.replace(" ", "").split(",")]
            except ValueError:
                continue  # the program reader names malformed values
            what = f"{option} {name}={text}"
            xyz = np.asarray(values[:3]) * LENGTH_SCALES_M[unit]
            if option == "--tool":
                check_tool(xyz, unit, what)
            else:
                check_frame(xyz, unit, reach_m, what)
            if angles == "deg":
                check_degrees(values[3:6], what)
            elif angles == "rad":
                check_radians(values[3:6], what)


def unused_conditions(calibrated: Robot, payload, temperature) -> list[str]:
    """Warnings for a ``payload`` / ``temperature`` given to a model without the term that uses it."""
    terms = condition_terms(calibrated)
    return [f"{option} is not used: the model of {calibrated.name} has no {term} term"
            for option, term, value in (("--payload", "payload", payload),
                                        ("--temperature", "thermal", temperature))
            if value is not None and term not in terms]


def as_frames(d: Dialect, given) -> dict[str, np.ndarray]:
    """name -> 4x4 (m) from name -> 4x4 or text in the dialect's pose notation."""
    return {str(k): d.frame_from_text(v) if isinstance(v, str) else np.asarray(v, float)
            for k, v in (given or {}).items()}


def check_language(programs, references, dialect: str | None) -> None:
    """No Cartesian target was found: refuse when the ``programs`` (paths as given) are in another
    language than their suffix says (each language's ``signature``). A language named with
    ``--format`` (``dialect``) is never overridden."""
    if dialect is not None:
        return
    given = [programs] if isinstance(programs, str | Path) else list(programs)
    texts = {p: Path(p).read_text(encoding="utf-8", errors="replace")
             for p in [*given, *references] if not Path(p).is_dir()}  # a folder: its files
    language = _language([Path(p) for p in given], dialect)
    if language is None:
        return
    for path in (p for p in given if p in texts):
        text = texts[path]
        if re.search(language.signature, text, re.M | re.I):
            continue
        other = [d for d in dialects() if d.key != language.key and re.search(d.signature, text, re.M | re.I)]
        if other:
            raise DataError(f"{path} looks like {other[0].title or other[0].name}, not "
                            f"{language.title or language.name} as its name says: give --format "
                            f"{other[0].key} (or name it {other[0].suffixes[0]})")
