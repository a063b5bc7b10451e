"""Simulated FANUC TP programs with known truth, for tests and benchmarks
(:mod:`robocal.programs.simulate`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.kinematics.model import Robot
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.writing import program_poses, wpr_text, zyx_angles


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
        pos += [f"P[{i + 1}]{{", "   GP1:", f"\tUF : 1, UT : 1,\t\tCONFIG : '{d.scheme.text(cfg[i])}',",
                f"\tX = {p_mm[i, 0]:9.3f}  mm,\tY = {p_mm[i, 1]:9.3f}  mm,\tZ = {p_mm[i, 2]:9.3f}  mm,",
                f"\tW = {rpw[i, 2]:9.3f} deg,\tP = {rpw[i, 1]:9.3f} deg,\tR = {rpw[i, 0]:9.3f} deg", "};"]
    text = [f"/PROG  {name.upper()}", "/ATTR", "DEFAULT_GROUP\t= 1,*,*,*,*;", "/MN",
            "   0:  UFRAME_NUM=1 ;", "   0:  UTOOL_NUM=1 ;", *mn, "/POS", *pos, "/END", ""]
    path = folder / f"{name}.ls"
    path.write_text("\r\n".join(text))
    return [path], {"1": wpr_text(tool)}, {"1": wpr_text(frame)}
