"""Inverse kinematics: closed-form OPW solver, numeric IK for any model, globally optimal path."""

from robocal.ik.numeric import IKResult, solve
from robocal.ik.opw_ik import solve_all
from robocal.ik.path import PathResult, default_weights, plan_path

__all__ = ["IKResult", "PathResult", "default_weights", "plan_path", "solve", "solve_all"]
