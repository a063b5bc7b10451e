"""Simulated FANUC TP programs with known truth, for tests and benchmarks
(:mod:`robocal.programs.simulate`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.kinematics.model import Robot
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.fanuc.posreg import position_block
from robocal.programs.dialects.writing import program_poses, wpr_text, zyx_angles

DECIMALS = 3  # a test program's positions: 1 um and 1e-3 deg, as the pendant writes them


def write_test_program(d: Dialect, folder: Path, nominal: Robot, q: np.ndarray, tool: np.ndarray,
                       frame: np.ndarray, name: str,
                       variables: bool = False) -> tuple[list[Path], dict, dict]:
    """A FANUC TP program visiting joints ``q`` ``(N, 6)`` (rad) of ``nominal`` with TCP ``tool``
    in ``frame`` (4x4, m): :func:`robocal.programs.simulate.write_program`."""
    P, cfg = program_poses(d, nominal, q, tool, frame)
    p_mm = P[:, :3, 3] * 1e3
    n = len(q)
    rpw = zyx_angles(P[:, :3, :3])
    mn = [f"{i + 1:4d}:{'J' if i % 5 == 0 else 'L'} P[{i + 1}] {'100%' if i % 5 == 0 else '500mm/sec'} "
          "CNT50    ;" for i in range(n)]
    pos = []
    for i in range(n):
        pos += position_block(i + 1, "1", "1", d.scheme.text(cfg[i]), (*p_mm[i], *rpw[i, ::-1]), DECIMALS)
    text = [f"/PROG  {name.upper()}", "/ATTR", "DEFAULT_GROUP\t= 1,*,*,*,*;", "/MN",
            "   0:  UFRAME_NUM=1 ;", "   0:  UTOOL_NUM=1 ;", *mn, "/POS", *pos, "/END", ""]
    path = folder / f"{name}.ls"
    path.write_text("\r\n".join(text))
    return [path], {"1": wpr_text(tool)}, {"1": wpr_text(frame)}
