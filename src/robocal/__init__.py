"""robocal: kinematic calibration, compensation and trajectory IK for serial industrial robots."""

from robocal import ik  # rc.ik.solve_all, rc.ik.solve, rc.ik.plan_path
from robocal.calibration import CalibrationResult, analyze, calibrate
from robocal.campaign import CampaignResult, Constraints, Tracker, plan_poses
from robocal.compensate import compensate
from robocal.data.measurements import Measurements
from robocal.data.registration import register
from robocal.data.simulate import simulate_tracker
from robocal.errors import (
    DataError,
    IdentificationError,
    ModelError,
    PlausibilityError,
    RobocalError,
    UnitError,
    UnreachableError,
)
from robocal.evaluate import evaluate
from robocal.kinematics.model import Robot
from robocal.programs import FilterResult, filter_program
from robocal.tcp import ToolCalibration, identify_tcp
from robocal.version import __version__

__all__ = [
    "CalibrationResult",
    "FilterResult",
    "ToolCalibration",
    "CampaignResult",
    "Constraints",
    "Tracker",
    "Measurements",
    "analyze",
    "calibrate",
    "evaluate",
    "plan_poses",
    "register",
    "simulate_tracker",
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
    "filter_program",
    "identify_tcp",
    "ik",
]
