"""Simulated Yaskawa INFORM programs with known truth, for tests and benchmarks
(:mod:`robocal.programs.simulate`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.kinematics.model import Robot
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.writing import program_poses, wpr_text


def write_test_program(d: Dialect, folder: Path, nominal: Robot, q: np.ndarray, tool: np.ndarray,
                       frame: np.ndarray, name: str,
                       variables: bool = False) -> tuple[list[Path], dict, dict]:
    """A Yaskawa INFORM program visiting joints ``q`` ``(N, 6)`` (rad) of ``nominal`` with TCP ``tool``
    in ``frame`` (4x4, m): :func:`robocal.programs.simulate.write_program`."""
    P, cfg = program_poses(d, nominal, q, tool, frame)
    n = len(q)
    values = d.from_pose(P, np.zeros((n, 6)))
    pos, last = [], ""
    for i in range(n):
        form = d.scheme.text(cfg[i])
        if form != last:
            pos.append(f"///RCONF {form},0,0")
            last = form
        pos.append(f"C{i:05d}=" + ",".join([f"{v:.3f}" for v in values[i, :3]]
                                            + [f"{v:.4f}" for v in values[i, 3:]]))
    moves = [f"MOVJ C{i:05d} VJ=50.00" if i % 5 == 0 else f"MOVL C{i:05d} V=500.0 PL=3" for i in range(n)]
    text = ["/JOB", f"//NAME {name.upper()}", "//POS", f"///NPOS {n},0,0,0,0,0", "///USER 1", "///TOOL 1",
            "///POSTYPE USER", "///RECTAN", *pos, "//INST", "///DATE 2000/01/01 00:00", "///ATTR SC,RW",
            "///GROUP1 RB1", "NOP", *moves, "END", ""]
    path = folder / f"{name.upper()}.JBI"
    path.write_bytes("\r\n".join(text).encode())
    return [path], {"1": wpr_text(tool)}, {"1": wpr_text(frame)}
