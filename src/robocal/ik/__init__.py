"""Inverse kinematics: closed-form OPW and UR solvers, numeric IK for any model, globally optimal path.

``rc.ik`` holds:

- `solve_all`: every closed-form solution (8 branches) of an OPW or UR robot, vectorised over
  poses;
- `solve`: numeric IK for any model (a calibrated one, with joint-error terms), seeded per pose,
  returning an `IKResult` with the residual errors and a converged flag;
- `plan_path`: the joints along a whole path of poses with the least weighted joint travel over
  every branch and turn (a `PathResult`); `default_weights` are its joint weights.

Poses are world TCP poses ``(N, 4, 4)`` in metres, joints ``(N, n)`` in radians.

See Also
--------
rc.ik.solve_all : Every solution of each target.
rc.ik.solve : One solution of each target.
rc.ik.plan_path : The solutions of a path that move the joints least.

Examples
--------
>>> import numpy as np
>>> import robocal as rc
>>> robot = rc.Robot.from_catalog("abb_irb2600")
>>> q = np.array([[0.1, -0.2, 0.3, 0.4, 0.5, 0.6]])
>>> pose = robot.fk(q)
>>> rc.ik.solve_all(robot, pose).shape  # 8 closed-form branches of 6 joints
(1, 8, 6)
>>> result = rc.ik.solve(robot, pose, seeds=q + 0.05)  # numeric, from a nearby seed
>>> bool(result.converged.all()), bool(np.allclose(result.joints, q))
(True, True)
"""

from robocal.ik.closed_form import solve_all
from robocal.ik.numeric import IKResult, solve
from robocal.ik.path import PathResult, default_weights, plan_path

__all__ = ["IKResult", "PathResult", "default_weights", "plan_path", "solve", "solve_all"]
