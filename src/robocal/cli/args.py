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


def load_measurements(path: str, robot, quiet: bool = False, fanuc_coupled: bool = False,
                      model_used: bool = True):
    """:meth:`Measurements.load` of ``path`` checked against ``robot``, printing how the reader
    interpreted the file (repeated readings grouped into poses; warnings always) and, when
    ``model_used`` (``robot`` is the model the command applies), the recorded conditions it
    has no term for; ``fanuc_coupled``: the joints are a FANUC controller's (J3 from the
    horizontal), converted to the catalog's."""
    from robocal.data.joint_conventions import fanuc_decoupled_data
    from robocal.data.measurements import Measurements

    data = Measurements.load(path, robot=robot)
    if fanuc_coupled:
        data = fanuc_decoupled_data(data)
    used = [data.unused_conditions(robot), *data.missing_conditions(robot)] if model_used else []
    notes = [*data.notes, *used]
    for note in filter(None, notes):
        if not quiet or note.startswith("WARNING"):
            print(note if note.startswith("WARNING") else f"note: {note}")
    return data


def payload_si(values: list[float] | None) -> list[float] | None:
    """``--payload KG[,X,Y,Z]`` (kg, mm) -> [kg, x, y, z] (kg, m); None when not given."""
    from robocal.core.errors import DataError

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

    from robocal.core.errors import DataError

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
           ".urdf": "URDF", ".npz": "npz", ".mod": "RAPID", ".src": "KRL", ".script": "URScript", ".ls": "TP",
           ".jbi": "JBI"}


def check_format(path, kind: str, option: str, hint: str = "") -> None:
    """Refuse writing ``kind`` (a FORMATS value) into ``path`` named for another known format
    (``-o result.json`` for a model YAML); unknown or no suffixes are allowed."""
    from pathlib import Path

    from robocal.core.errors import DataError

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
    from robocal.core.errors import DataError
    from robocal.kinematics.catalog import catalog_names
    from robocal.kinematics.model import load_model

    if nominal is None and robot.name not in catalog_names():
        return None
    model = load_model(nominal or robot.name)
    if model.n_joints != robot.n_joints:
        raise DataError(f"--nominal {model.name} has {model.n_joints} joints, the model {robot.n_joints}: "
                        "give the controller's model of this robot")
    return model


def check_tool_mm(xyz, option: str) -> None:
    """Refuse a tool translation (mm) whose magnitude says another unit (metres, or not a length
    a tool has): :func:`robocal.core.magnitudes.check_tool`."""
    import numpy as np

    from robocal.core.magnitudes import check_tool

    check_tool(np.asarray(xyz, dtype=float) * 1e-3, "mm", option)


def tool_frame(text: str, option: str):
    """A tool frame ``x,y,z,rx,ry,rz`` (mm, deg) -> 4x4 (m), refused when its magnitudes say
    another unit (:func:`check_tool_mm`, :func:`robocal.core.magnitudes.check_degrees`)."""
    from robocal.core.magnitudes import check_degrees
    from robocal.deploy.compensation import frame_from_text

    T = frame_from_text(text, option)
    values = [float(v) for v in text.replace(" ", "").split(",") if v]
    check_tool_mm(values[:3], f"{option} {text}")
    check_degrees(values[3:], f"{option} {text}")
    return T


def diagnosed(error, robot, datasets, frame_fitted: bool = True):
    """``error`` (a PlausibilityError) with the data's own diagnosis
    (:func:`robocal.trust.diagnosis.diagnose`) put first when they tell more (a swapped or
    sign-flipped joint column, a mirrored frame, the odd file, a frame that needs --fit-frame)."""
    from robocal.trust.diagnosis import diagnose

    why = diagnose(robot, datasets, frame_fitted=frame_fitted)
    return error if why is None else type(error)(f"{why} (the check: {error})")


def print_warnings(command: str, warnings) -> None:
    """The warnings of a quiet run on stderr, one line each (``--quiet`` silences progress and
    summaries, never a warning)."""
    import sys

    for warning in warnings:
        print(f"robocal {command}: warning: {' '.join(str(warning).split())}", file=sys.stderr)


def load_calibrated_and_nominal(calibrated: str, nominal: str, option: str = "--calibrated"):
    """(calibrated Robot from a model file, the controller's nominal Robot from a catalog name or
    model file), refused in one line when the two look swapped: a catalog name given as the
    calibrated model and a model file as the nominal one, or a calibrated file (its parameters
    moved from its own nominal values) given as the nominal model and an uncalibrated one as the
    calibrated model."""
    from pathlib import Path

    import numpy as np

    from robocal.core.errors import DataError
    from robocal.kinematics.catalog import catalog_names
    from robocal.kinematics.model import Robot, load_model

    swapped = (f"{option} {calibrated} and --nominal {nominal} look swapped: give {option} {nominal} "
               f"--nominal {calibrated}")
    if not Path(calibrated).exists() and calibrated in catalog_names() and Path(nominal).is_file():
        raise DataError(f"{swapped} ({calibrated} is a catalog robot, the controller's model; {nominal} a "
                        "model file)")
    cal, nom = Robot.load(calibrated), load_model(nominal)
    n = len(cal.nominal)

    def moved(robot) -> bool:
        return not np.allclose(robot.values[:n], robot.nominal, rtol=0.0, atol=1e-12)

    if Path(nominal).is_file() and moved(nom) and not moved(cal):
        raise DataError(f"{swapped} ({nominal} holds a calibration: its parameters moved from its nominal "
                        f"values; {calibrated} holds none)")
    return cal, nom


def add_fanuc_coupled(parser) -> None:
    """The option that reads joint logs of a FANUC controller (J3 counted from the horizontal)."""
    from robocal.data.joint_conventions import COUPLED_OPTION

    parser.add_argument(COUPLED_OPTION, dest="fanuc_coupled", action="store_true",
                        help="the joints are a FANUC controller's (J3 counted from the horizontal, J3 + J2 "
                             "of the catalog's; robocal's --fanuc programs take them so): convert them")


def load_prediction(path, calibrated, outputs: list):
    """The accuracy prediction of a result JSON (``--result`` of compensate and filter; None
    without it), checked against the calibrated model (the same parameters) and the ``outputs``
    (none of them is the JSON)."""
    if path is None:
        return None
    from robocal.calibration.result import load_result
    from robocal.core.errors import DataError
    from robocal.core.io import check_outputs
    from robocal.trust.coverage import Prediction

    check_outputs(outputs, [path])
    section = load_result(path).get("predicted_accuracy")
    if not isinstance(section, dict) or not isinstance(section.get("model"), dict):
        raise DataError(f"{path} has no predicted_accuracy section: calibrate again with --json to get one")
    prediction = Prediction.from_dict(section["model"])
    prediction.error_mm(calibrated, calibrated.limits.mean(axis=1)[None])  # DataError: another model's
    return prediction
