"""What the user gives the filter beside the program files, checked: ``--tool`` / ``--frame`` /
``--robot-base`` values whose magnitudes say another unit than the language's notation, tool data
that differ from the program's own, a payload or temperature the model has no term for, and files
that read as another language than their suffix says (:func:`robocal.programs.filter_program`)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.core.magnitudes import LENGTH_SCALES_M, check_degrees, check_frame, check_radians, check_tool
from robocal.kinematics.joint_errors import condition_terms
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import pose_error
from robocal.programs.dialects.base import Dialect
from robocal.programs.registry import DIALECTS, dialect_named, dialects, language_of

# a --tool this far from the program's own tool data of the same name is another tool: a warning
TOOL_DISAGREE_MM = 0.5
TOOL_DISAGREE_DEG = 0.1


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


def tool_disagreements(d: Dialect, declared: dict[str, np.ndarray], tools) -> list[str]:
    """One warning per ``tools`` entry (name -> 4x4 m, or text in ``d``'s pose notation) that
    replaces tool data the program holds differently, naming both. ``declared``: the tool data
    the program files hold without ``tools`` (`Program.declared_tools` of the filter's parse)."""
    if not tools:
        return []
    out = []
    for key, T in {d.name_key(k): v for k, v in as_frames(d, tools).items()}.items():
        own = declared.get(key)
        if own is None:
            continue
        err = pose_error(np.asarray(own)[None], np.asarray(T)[None])[0]
        mm, deg = np.linalg.norm(err[:3]) * 1e3, np.rad2deg(np.linalg.norm(err[3:]))
        if mm > TOOL_DISAGREE_MM or deg > TOOL_DISAGREE_DEG:
            name = next(k for k in tools if d.name_key(k) == key)
            own_text = ", ".join(f"{v:.4g}" for v in np.r_[own[:3, 3] * 1e3])
            out.append(f"--tool {name}={tools[name]} replaces the program's own tool data {name} (TCP at "
                       f"{own_text} mm on the flange) and differs from it by {mm:.3g} mm, {deg:.3g} deg: the "
                       "controller moves with the tool data it holds; make sure --tool is what it holds")
    return out


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
