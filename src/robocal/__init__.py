"""robocal: kinematic calibration, compensation and trajectory IK for serial industrial robots."""

from __future__ import annotations

import importlib

from robocal.core.errors import (
    DataError,
    IdentificationError,
    ModelError,
    PlausibilityError,
    RobocalError,
    UnitError,
    UnreachableError,
)
from robocal.core.version import __version__

# The API is imported on first use (PEP 562): `import robocal` and the command line start fast, and
# Ctrl-C during the heavy imports reaches the command line's handler (one line, exit 130).
_LAZY = {
    "ik": "robocal.ik",  # rc.ik.solve_all, rc.ik.solve, rc.ik.plan_path
    "CalibrationResult": "robocal.calibration.result", "analyze": "robocal.calibration.pipeline",
    "calibrate": "robocal.calibration.pipeline",
    "CampaignResult": "robocal.campaign", "Constraints": "robocal.campaign", "Tracker": "robocal.campaign",
    "plan_poses": "robocal.campaign",
    "compensate": "robocal.deploy.compensation",
    "export_urdf_like": "robocal.deploy.urdf_like",  # the calibrated kinematics in the vendor's URDF
    "Measurements": "robocal.data.measurements",
    "register": "robocal.data.registration",
    "Conditions": "robocal.kinematics.conditions",  # the rows' conditions for Robot.fk / jacobian
    "simulate_tracker": "robocal.data.simulate",
    "simulate_markers": "robocal.data.simulate_instruments",
    "simulate_camera": "robocal.data.simulate_instruments",
    "evaluate": "robocal.calibration.evaluation",
    "Robot": "robocal.kinematics.model", "load_model": "robocal.kinematics.model",
    "Cell": "robocal.kinematics.workcell", "Positioner": "robocal.kinematics.workcell",
    "load_cell": "robocal.kinematics.workcell",
    "CellMeasurements": "robocal.data.cell_measurements",  # a cell's rows, split per body
    "simulate_cell": "robocal.data.cell_simulation", "CellCalibration": "robocal.calibration.cell",
    "FilterResult": "robocal.programs", "filter_program": "robocal.programs",
    "ToolCalibration": "robocal.deploy.tcp", "identify_tcp": "robocal.deploy.tcp",
    "sample_path": "robocal.demo",  # the small files the how-to pages start from
}


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(f"module 'robocal' has no attribute {name!r}")
    module = importlib.import_module(_LAZY[name])
    value = module if name == "ik" else getattr(module, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "CalibrationResult",
    "Cell",
    "CellCalibration",
    "CellMeasurements",
    "FilterResult",
    "ToolCalibration",
    "CampaignResult",
    "Constraints",
    "Tracker",
    "Measurements",
    "Positioner",
    "analyze",
    "calibrate",
    "sample_path",
    "evaluate",
    "plan_poses",
    "register",
    "simulate_tracker",
    "simulate_markers",
    "simulate_camera",
    "DataError",
    "IdentificationError",
    "ModelError",
    "PlausibilityError",
    "RobocalError",
    "Robot",
    "UnitError",
    "UnreachableError",
    "__version__",
    "compensate",
    "export_urdf_like",
    "filter_program",
    "identify_tcp",
    "ik",
    "load_cell",
    "simulate_cell",
    "load_model",
]
