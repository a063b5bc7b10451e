"""Simulated URScript programs with known truth, for tests and benchmarks
(:mod:`robocal.programs.simulate`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.kinematics.model import Robot
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.writing import frame_text, program_poses


def write_test_program(d: Dialect, folder: Path, nominal: Robot, q: np.ndarray, tool: np.ndarray,
                       frame: np.ndarray, name: str,
                       variables: bool = False) -> tuple[list[Path], dict, dict]:
    """A URScript program visiting joints ``q`` ``(N, 6)`` (rad) of ``nominal`` with TCP ``tool``
    in ``frame`` (4x4, m): :func:`robocal.programs.simulate.write_program`."""
    P, cfg = program_poses(d, nominal, q, tool, frame)
    n = len(q)
    rv = Rotation.from_matrix(P[:, :3, :3]).as_rotvec()
    lines = [f"def {name}():", "  set_tcp(p[" + frame_text(tool, "rotvec") + "])",
             "  global Cell=p[" + frame_text(frame, "rotvec") + "]",
             "  movej([" + ", ".join(f"{v:.6f}" for v in q[0]) + "], a=1.4, v=1.05)"]
    poses = ["p[" + ", ".join(f"{v:.6f}" for v in (*P[i, :3, 3], *rv[i])) + "]" for i in range(n)]
    if variables:
        lines += [f"  global Waypoint_{i + 1}_p={pose}" for i, pose in enumerate(poses)]
        poses = [f"Waypoint_{i + 1}_p" for i in range(n)]
    lines += [f"  movel(pose_trans(Cell, {pose}), a=1.2, v=0.25)" for pose in poses]
    lines += ["end", f"{name}()", ""]
    path = folder / f"{name}.script"
    path.write_text("\n".join(lines))
    return [path], {}, {}
