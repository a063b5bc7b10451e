"""Robot model, forward kinematics, identification Jacobian, catalog."""

from robocal.kinematics.model import Robot

__all__ = ["Robot"]
