"""Simulated ABB RAPID programs with known truth, for tests and benchmarks
(:mod:`robocal.programs.simulate`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.kinematics.model import Robot
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.writing import program_poses, quaternions


def write_test_program(d: Dialect, folder: Path, nominal: Robot, q: np.ndarray, tool: np.ndarray,
                       frame: np.ndarray, name: str,
                       variables: bool = False) -> tuple[list[Path], dict, dict]:
    """An ABB RAPID program visiting joints ``q`` ``(N, 6)`` (rad) of ``nominal`` with TCP ``tool``
    in ``frame`` (4x4, m): :func:`robocal.programs.simulate.write_program`."""
    P, cfg = program_poses(d, nominal, q, tool, frame)
    p_mm = P[:, :3, 3] * 1e3
    n = len(q)
    qt, qf = quaternions(tool[None, :3, :3])[0], quaternions(frame[None, :3, :3])[0]
    t_mm, f_mm = tool[:3, 3] * 1e3, frame[:3, 3] * 1e3
    quat = quaternions(P[:, :3, :3])
    lines = [f"MODULE {name}", "    ! simulated program", "    PERS tooldata tReal:=[TRUE,[["
             + ",".join(f"{v:.3f}" for v in t_mm) + "],[" + ",".join(f"{v:.8f}" for v in qt)
             + "]],[1,[0,0,50],[1,0,0,0],0,0,0]];",
             "    PERS wobjdata wCell:=[FALSE,TRUE,\"\",[[" + ",".join(f"{v:.3f}" for v in f_mm) + "],["
             + ",".join(f"{v:.8f}" for v in qf) + "]],[[0,0,0],[1,0,0,0]]];"]
    for i in range(n):
        cx, c1, c4, c6 = cfg[i]
        lines.append(f"    CONST robtarget p{i}:=[[{p_mm[i, 0]:.2f},{p_mm[i, 1]:.2f},{p_mm[i, 2]:.2f}],["
                     + ",".join(f"{v:.8f}" for v in quat[i]) + f"],[{c1},{c4},{c6},{cx}],"
                     "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];")
    moves = [f"        Move{'J' if i % 5 == 0 else 'L'} p{i}, v500, z1, tReal\\WObj:=wCell;"
             for i in range(n)]
    lines += ["    PROC main()", *moves, "    ENDPROC", "ENDMODULE", ""]
    path = folder / f"{name}.mod"
    path.write_text("\r\n".join(lines))
    return [path], {}, {}
