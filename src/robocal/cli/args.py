"""Argument types and checks shared by the subcommands: numbers, loading measurements with the
reader's notes, distinct inputs, output formats, tool units, the controller's model, diagnoses."""

from __future__ import annotations

import argparse
from collections.abc import Callable


def numbers(count: int | None, unit_hint: str) -> Callable[[str], list[float]]:
    """An argparse ``type``: ``count`` comma-separated numbers (e.g. ``X,Y,Z``; None: one or more,
    the command checks how many); ``unit_hint`` completes the error message (e.g. ``"X,Y,Z in mm"``)."""

    def parse(text: str) -> list[float]:
        try:
            values = [float(v) for v in text.replace(" ", "").split(",") if v]
        except ValueError:
            values = []
        if not values or (count is not None and len(values) != count):
            raise argparse.ArgumentTypeError(f"expected {count or 'some'} comma-separated numbers "
                                             f"({unit_hint}), got {text!r}")
        return values

    return parse


def load_measurements(path: str, robot, quiet: bool = False, model_used: bool = True):
    """:meth:`Measurements.load` of ``path`` checked against ``robot``, printing how the reader
    interpreted the file (repeated readings grouped into poses; warnings always) and, when
    ``model_used`` (``robot`` is the model the command applies), the recorded conditions it
    has no term for."""
    from robocal.data.measurements import Measurements

    data = Measurements.load(path, robot=robot)
    used = [data.unused_conditions(robot), *data.missing_conditions(robot)] if model_used else []
    notes = [*data.notes, *used]
    for note in filter(None, notes):
        if not quiet or note.startswith("WARNING"):
            print(note if note.startswith("WARNING") else f"note: {note}")
    return data


def payload_si(values: list[float] | None) -> list[float] | None:
    """``--payload KG[,X,Y,Z]`` (kg, mm) -> [kg, x, y, z] (kg, m); None when not given."""
    from robocal.errors import DataError

    if values is None:
        return None
    if len(values) not in (1, 4):
        raise DataError(f"--payload takes KG or KG,X,Y,Z (centre of mass in mm), got {len(values)} numbers")
    return [values[0], *(v * 1e-3 for v in values[1:])]


def conditions_unused(robot, args) -> list[str]:
    """Warnings for ``--payload`` / ``--temperature`` given to a model without the term that uses it."""
    from robocal.kinematics.joint_errors import condition_terms

    terms = condition_terms(robot)
    return [f"{option} is not used: the model of {robot.name} has no {term} term"
            for option, term, value in (("--payload", "payload", args.payload),
                                        ("--temperature", "thermal", args.temperature))
            if value is not None and term not in terms]


TWICE = "each reading would count twice (the noise estimate shrinks, the result looks better than it is)"


def check_distinct_inputs(paths, what: str = "input files", why: str = TWICE) -> None:
    """Refuse a file given twice (the same path, or two files with identical contents): each of
    its readings would count twice, the noise estimate shrink by sqrt 2 and the judgement lie."""
    import hashlib
    from pathlib import Path

    from robocal.errors import DataError

    seen: dict = {}
    for path in (p for p in paths if p is not None):
        p = Path(path)
        if not p.is_file():
            continue  # the reader names a missing file
        key = hashlib.sha256(p.read_bytes()).hexdigest()
        if key in seen:
            same = "is given twice" if p.resolve() == Path(seen[key]).resolve() else \
                f"has the same contents as {seen[key]}"
            raise DataError(f"{path} {same} among the {what}: {why}; give each file once")
        seen[key] = path


# output suffix -> the format written there; an output named for another format is refused
FORMATS = {".json": "JSON", ".yaml": "YAML", ".yml": "YAML", ".csv": "CSV", ".html": "HTML", ".htm": "HTML",
           ".urdf": "URDF", ".npz": "npz", ".mod": "RAPID", ".src": "KRL", ".script": "URScript", ".ls": "TP"}


def check_format(path, kind: str, option: str, hint: str = "") -> None:
    """Refuse writing ``kind`` (a FORMATS value) into ``path`` named for another known format
    (``-o result.json`` for a model YAML); unknown or no suffixes are allowed."""
    from pathlib import Path

    from robocal.errors import DataError

    if path is None:
        return
    named = FORMATS.get(Path(path).suffix.lower())
    if named is not None and named != kind:
        suffix = next(s for s, k in FORMATS.items() if k == kind)
        raise DataError(f"{option} {path}: {option} writes {kind}, but the name says {named}; name it "
                        f"{Path(path).with_suffix(suffix).name}{hint}")


def controller_for(robot, nominal: str | None):
    """The controller's model of ``robot`` (its base and flange, tool0): ``nominal`` (catalog name
    or YAML), else the catalog robot of the model's name, else None."""
    from robocal.errors import DataError
    from robocal.kinematics.catalog import catalog_names
    from robocal.kinematics.model import load_model

    if nominal is None and robot.name not in catalog_names():
        return None
    model = load_model(nominal or robot.name)
    if model.n_joints != robot.n_joints:
        raise DataError(f"--nominal {model.name} has {model.n_joints} joints, the model {robot.n_joints}: "
                        "give the controller's model of this robot")
    return model


# a tool or TCP offset (mm) whose every coordinate is below this but not all zero is in metres
TOOL_MM_FLOOR = 2.0
TOOL_MM_CEILING = 5000.0  # no tool reaches 5 m from the flange: the values are not mm


def check_tool_mm(xyz, option: str) -> None:
    """Refuse a tool translation (mm) whose magnitude says another unit (metres, micrometres)."""
    import numpy as np

    from robocal.errors import UnitError

    xyz = np.abs(np.asarray(xyz, dtype=float))
    if 0 < xyz.max() < TOOL_MM_FLOOR:
        raise UnitError(f"{option}: a tool {np.linalg.norm(xyz):.3g} mm from the flange centre: these "
                        f"values look like metres; give mm (e.g. {','.join(f'{v * 1e3:g}' for v in xyz)})")
    if xyz.max() > TOOL_MM_CEILING:
        raise UnitError(f"{option}: a tool {np.linalg.norm(xyz) / 1e3:.3g} m from the flange: these values "
                        "are not mm; give the offset in mm")


# angles (deg) within this of a multiple of pi/12 *in radians* (0.2618, 0.5236, 0.7854, 1.5708..)
# are radians typed where degrees belong
RADIAN_LIKE_TOL = 5e-4


def check_degrees(angles, option: str) -> None:
    """Refuse rotation angles given in degrees that are clearly radians (pi/4 = 0.785, pi/2 = 1.571)."""
    import numpy as np

    from robocal.errors import UnitError

    a = np.asarray(angles, dtype=float)
    steps = a / (np.pi / 12)
    radian_like = (np.abs(a) > 0.1) & (np.abs(a) <= 2 * np.pi + 1e-9) & \
        (np.abs(steps - np.round(steps)) * np.pi / 12 < RADIAN_LIKE_TOL)
    if radian_like.any():
        raise UnitError(f"{option}: {', '.join(f'{v:g}' for v in a[radian_like])} look like radians "
                        f"({', '.join(f'{v:g} rad = {np.rad2deg(v):g} deg' for v in a[radian_like])}); the "
                        "angles are in degrees")


def tool_frame(text: str, option: str):
    """A tool frame ``x,y,z,rx,ry,rz`` (mm, deg) -> 4x4 (m), refused when its magnitudes say
    another unit (:func:`check_tool_mm`, :func:`check_degrees`)."""
    from robocal.compensate import frame_from_text

    T = frame_from_text(text, option)
    values = [float(v) for v in text.replace(" ", "").split(",") if v]
    check_tool_mm(values[:3], f"{option} {text}")
    check_degrees(values[3:], f"{option} {text}")
    return T


def diagnosed(error, robot, datasets, frame_fitted: bool = True):
    """``error`` (a PlausibilityError) with the data's own diagnosis (:func:`robocal.diagnose.diagnose`)
    put first when they tell more (a swapped or sign-flipped joint column, a mirrored frame, the odd
    file, a frame that needs --fit-frame)."""
    from robocal.diagnose import diagnose

    why = diagnose(robot, datasets, frame_fitted=frame_fitted)
    return error if why is None else type(error)(f"{why} (the check: {error})")


def print_warnings(command: str, warnings) -> None:
    """The warnings of a quiet run on stderr, one line each (``--quiet`` silences progress and
    summaries, never a warning)."""
    import sys

    for warning in warnings:
        print(f"robocal {command}: warning: {' '.join(str(warning).split())}", file=sys.stderr)
