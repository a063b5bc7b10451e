"""The models a robot's programs and targets are corrected with, loaded and checked: the calibrated
model and the controller's nominal one (refused when they look swapped), the controller's model of
a calibrated robot, the calibration's accuracy prediction, and the options that go with them (a
tool frame, a payload)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.errors import DataError, ModelError
from robocal.core.io import check_outputs
from robocal.core.magnitudes import check_degrees, check_frame, check_tool
from robocal.deploy.compensation import controller_model, frame_from_values, frame_values, rotation_values
from robocal.kinematics.catalog import catalog_names
from robocal.kinematics.cell_file import is_workcell
from robocal.kinematics.model import Robot, load_model
from robocal.kinematics.model_file import read_model_data
from robocal.kinematics.workcell import Cell, load_cell
from robocal.trust.coverage import Prediction


def load_model_pair(calibrated: str, nominal: str, option: str = "--calibrated") -> tuple[Robot, Robot]:
    """The calibrated model (a model file) and the controller's nominal one (a catalog name or a
    model file), refused when the two look swapped.

    Swapped: a catalog name given as the calibrated model and a model file as the nominal one, or
    a calibrated file (its parameters moved from its own nominal values) given as the nominal
    model and an uncalibrated one as the calibrated model.

    Parameters
    ----------
    calibrated : str
        Path of the calibrated model YAML (``robocal calibrate -o``).
    nominal : str
        Catalog name or model YAML of the controller's model.
    option : str
        How the calibrated model was named to the user (``--calibrated``, ``calibrated model``),
        for the message.

    Returns
    -------
    tuple of Robot
        (calibrated, nominal).

    Raises
    ------
    DataError
        The two look swapped, or a file is missing or not a model.

    See Also
    --------
    rc.compensate : Uses the pair.
    rc.filter_program : Uses the pair.
    robocal.data.inputs.check_distinct_inputs : The input files checked distinct.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.deploy.models import load_model_pair
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> nominal.with_values({"a2": nominal.get("a2") + 1e-4}).save("calibrated.yaml")
    >>> calibrated, controller = load_model_pair("calibrated.yaml", "abb_irb2600")
    >>> controller.name, round((calibrated.get("a2") - controller.get("a2")) * 1e3, 3)  # mm
    ('abb_irb2600', 0.1)
    >>> load_model_pair("abb_irb2600", "calibrated.yaml")  # the two swapped
    Traceback (most recent call last):
    ...
    robocal.core.errors.DataError: --calibrated abb_irb2600 and --nominal calibrated.yaml look swapped: ...
    """
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


def load_models(calibrated: str, nominal: str,
                option: str = "--calibrated") -> tuple[Robot | Cell, Robot | Cell]:
    """`load_model_pair`, or both as cells (`robocal.load_cell`) when either file is a work cell
    with a positioner: a program's targets on the positioner's plate need the nominal cell and the
    calibrated one (`robocal.programs.positioner`); a catalog name or robot file given with a cell
    is a one-arm cell.

    Raises
    ------
    DataError
        What `load_model_pair` refuses; a cell file that does not load (its message).
    """
    if not any(_has_positioner(spec) for spec in (calibrated, nominal)):
        return load_model_pair(calibrated, nominal, option)
    try:
        return load_cell(calibrated), load_cell(nominal)
    except ModelError as exc:
        raise DataError(str(exc)) from None


def _has_positioner(spec: str) -> bool:
    path = Path(spec)
    if not path.is_file() or path.suffix.lower() not in (".yaml", ".yml"):
        return False
    data = read_model_data(path)
    return is_workcell(data) and any(k in data for k in ("positioner", "positioners"))


def controller_for(robot: Robot, nominal: str | None) -> Robot | None:
    """The controller's model of ``robot`` (its base and flange, tool0): ``nominal`` (catalog name
    or model YAML), else the catalog robot of the model's name, else None.

    Raises
    ------
    DataError
        ``nominal`` has another number of joints than ``robot``.
    """
    if nominal is None and robot.name not in catalog_names():
        return None
    model = load_model(nominal or robot.name)
    if model.n_joints != robot.n_joints:
        raise DataError(f"--nominal {model.name} has {model.n_joints} joints, the model {robot.n_joints}: "
                        "give the controller's model of this robot")
    return model


def load_prediction(path: str | None, calibrated: Robot | Cell, outputs: list) -> Prediction | None:
    """The accuracy prediction of a calibration's result JSON (None without ``path``), checked
    against the calibrated model (the same parameters) and the ``outputs`` (none of them is the
    JSON).

    Raises
    ------
    DataError
        The JSON has no prediction, belongs to another model, or is among ``outputs``.
    """
    if path is None:
        return None
    from robocal.calibration.result import result_prediction

    check_outputs(outputs, [path])
    if isinstance(calibrated, Cell):  # a cell calibration's prediction is its anchor arm's
        calibrated = calibrated.body(calibrated.anchor)
    return result_prediction(path, calibrated)


def payload_si(values: list[float] | None) -> list[float] | None:
    """A payload as given on the command line, KG[,X,Y,Z] (kg, mm) -> [kg, x, y, z] (kg, m); None
    when not given.

    Raises
    ------
    DataError
        Neither 1 nor 4 numbers.
    """
    if values is None:
        return None
    if len(values) not in (1, 4):
        raise DataError(f"--payload takes KG or KG,X,Y,Z (centre of mass in mm), got {len(values)} numbers")
    return [values[0], *(v * 1e-3 for v in values[1:])]


def check_tool_mm(xyz, option: str) -> None:
    """Refuse a tool translation (mm) whose magnitude says another unit (metres, or not a length
    a tool has): `robocal.core.magnitudes.check_tool`."""
    check_tool(np.asarray(xyz, dtype=float) * 1e-3, "mm", option)


def tool_frame(text: str, option: str) -> np.ndarray:
    """A tool frame ``x,y,z,rx,ry,rz`` (mm, deg) -> 4x4 (m), refused when its magnitudes say
    another unit (`check_tool_mm`, `robocal.core.magnitudes.check_degrees`)."""
    values = frame_values(text, option)
    check_tool_mm(values[:3], f"{option} {text}")
    check_degrees(values[3:], f"{option} {text}")
    return frame_from_values(values)


def tool_rotation(text: str, option: str) -> np.ndarray:
    """A tool's orientation ``rx,ry,rz`` (deg, fixed-axis XYZ) -> 3x3, refused when the angles
    look like radians (`robocal.core.magnitudes.check_degrees`)."""
    angles = rotation_values(text, option)
    check_degrees(angles, f"{option} {text}")
    return Rotation.from_euler("xyz", angles, degrees=True).as_matrix()


def planning_model(robot: Robot, nominal: Robot | None, tool: str = "flange") -> tuple[Robot, str]:
    """The model a path is planned on, and the frames its poses are in (said in words).

    ``nominal`` (the controller's model, `controller_for`; None for a robot outside the
    catalog): the calibrated model in the robot's base frame, its flange carrying ``tool``
    (``"flange"``, ``"measured"``: the model's own tool, or ``x,y,z,rx,ry,rz`` in mm, deg on the
    flange); without it, the model's world frame and its own tool (carrying ``tool``).
    """
    frame = None if tool in ("flange", "measured") else tool_frame(tool, "--tool")
    if nominal is not None and tool != "measured":
        frames = "the robot's base frame, " + ("the flange (tool0)" if frame is None else f"the tool {tool}")
        return controller_model(robot, nominal, tool=frame), frames
    if nominal is not None:
        return robot.with_frames(base=nominal.base), \
            "the robot's base frame, the model's own tool (e.g. the measured SMR)"
    carried = "its own tool" if frame is None else f"its tool carrying {tool}"
    return (robot if frame is None else robot.with_frames(tool=robot.tool @ frame),
            f"the model's world frame and {carried} ({robot.name} is not a catalog robot: give --nominal "
            "for the robot's base and flange)")


def robot_base_frame(base, reach_m: float) -> np.ndarray | None:
    """The controller's base frame 4x4 (m): ``base`` as given, or its text ``x,y,z,rx,ry,rz``
    (mm, deg) read and its magnitudes checked for a robot of ``reach_m``."""
    if not isinstance(base, str):
        return base
    values = frame_values(base, "--robot-base")
    frame = frame_from_values(values)
    what = f"--robot-base {base}"
    check_frame(frame[:3, 3], "mm", reach_m, what)
    check_degrees(values[3:], what)
    return frame
