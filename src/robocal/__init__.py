"""robocal: kinematic calibration, compensation and trajectory IK for serial industrial robots."""

from robocal import ik  # rc.ik.solve_all, rc.ik.solve, rc.ik.plan_path
from robocal.calibration import CalibrationResult, analyze, calibrate
from robocal.campaign import CampaignResult, Constraints, Tracker, plan_poses
from robocal.compensate import compensate
from robocal.data.measurements import Measurements
from robocal.data.registration import register
from robocal.data.simulate import simulate_tracker
from robocal.errors import (
    ConvergenceError,
    DataError,
    IdentificationError,
    ModelError,
    RobocalError,
    UnitError,
    UnreachableError,
)
from robocal.evaluate import evaluate
from robocal.kinematics.model import Robot

__version__ = "0.1.0"

__all__ = [
    "CalibrationResult",
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
    "ConvergenceError",
    "DataError",
    "IdentificationError",
    "ModelError",
    "RobocalError",
    "Robot",
    "UnitError",
    "UnreachableError",
    "compensate",
    "ik",
]
