"""Simulated robot programs with known truth, for tests and benchmarks.

:func:`write_program` writes a program in a vendor's syntax that visits given joint positions
with a real tool in a work object (base, user frame, feature), with the configuration data the
nominal controller shows at those joints. :func:`execute` runs a program as the controller
would: its targets through the nominal model's IK in the program's configuration, then the
TCP poses a robot (the true one) really reaches with those joints.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.ik import solve
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform
from robocal.programs.filter import as_frames, controller_joints, target_poses
from robocal.programs.registry import dialect_for, dialect_named
from robocal.programs.source import ProgramText


def write_program(dialect: str, folder, nominal: Robot, q: np.ndarray, tool: np.ndarray,
                  frame: np.ndarray, name: str = "sim", variables: bool = False
                  ) -> tuple[list[Path], dict, dict]:
    """Write a program in language ``dialect`` (a registry key; each language's
    ``simulated.py``) visiting joints ``q`` ``(N, 6)`` (rad) of ``nominal`` with TCP ``tool``
    in ``frame`` (4x4, m). Returns the files and the ``tools`` / ``frames`` to give the filter
    (text in the dialect's notation; empty when the program declares them). ``variables``
    (URScript): one pose variable per waypoint, ``global Waypoint_i_p=p[...]``, as PolyScope
    exports them, instead of literals in the motions."""
    return dialect_named(dialect).test_program(Path(folder), nominal, q, tool, frame, name, variables)


def execute(paths, robot: Robot, nominal: Robot, *, tools=None, frames=None, references=(),
            dialect: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Run program file(s) on ``robot`` (its links and base in the controller's base frame, its
    tool the flange) through ``nominal``'s IK in the program's configuration. Returns the TCP
    poses reached and the poses the program asks for, both ``(N, 4, 4)`` (m, base frame)."""
    paths = [Path(p) for p in ([paths] if isinstance(paths, str | Path) else paths)]
    d = dialect_for(paths, dialect)
    program = d.parse([ProgramText(p) for p in paths], as_frames(d, frames), as_frames(d, tools),
                      [ProgramText(p) for p in references])
    targets = program.targets
    _, P, W, tool = target_poses(d, program, targets)
    X = W @ P
    problems, warnings = [], []
    q = controller_joints(d, program, targets, nominal, X @ invert_transform(tool), problems, warnings)
    if problems:
        raise AssertionError(f"the controller cannot run {problems[:5]}")
    return robot.fk(q) @ tool, X


def touch_poses(robot: Robot, tool: np.ndarray, point: np.ndarray, n: int, rng, seed=None) -> np.ndarray:
    """Joints ``(n, 6)`` at which ``robot`` (flange model) touches ``point`` with ``tool``'s TCP,
    tilted up to +-35 deg about x and y and turned about z (a 4-point tool calibration);
    ``seed`` (6,) rad starts the numeric IK of robots without a closed form."""
    R = Rotation.from_euler("xyz", np.column_stack([180 + rng.uniform(-35, 35, n), rng.uniform(-35, 35, n),
                                                    rng.uniform(-90, 90, n)]), degrees=True).as_matrix()
    F = np.tile(np.eye(4), (n, 1, 1))
    F[:, :3, :3] = R
    F[:, :3, 3] = point - R @ tool[:3, 3]
    res = solve(robot, F, None if seed is None else np.tile(seed, (n, 1)))
    return res.joints[res.converged]
