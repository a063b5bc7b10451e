"""Inverse kinematics: closed-form OPW and UR solvers, numeric IK for any model, globally optimal path."""

from robocal.ik.closed_form import solve_all
from robocal.ik.numeric import IKResult, solve
from robocal.ik.path import PathResult, default_weights, plan_path

__all__ = ["IKResult", "PathResult", "default_weights", "plan_path", "solve", "solve_all"]
