"""robocal: kinematic calibration, compensation and trajectory IK for serial industrial robots."""

from robocal import ik  # rc.ik.solve_all, rc.ik.solve, rc.ik.plan_path
from robocal.compensate import compensate
from robocal.errors import (
    ConvergenceError,
    DataError,
    IdentificationError,
    ModelError,
    RobocalError,
    UnitError,
    UnreachableError,
)
from robocal.kinematics.model import Robot

__version__ = "0.1.0"

__all__ = [
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
