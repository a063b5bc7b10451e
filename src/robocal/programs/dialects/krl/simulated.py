"""Simulated KUKA KRL programs with known truth, for tests and benchmarks
(:mod:`robocal.programs.simulate`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.kinematics.model import Robot
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.writing import frame_text, program_poses, zyx_angles


def write_test_program(d: Dialect, folder: Path, nominal: Robot, q: np.ndarray, tool: np.ndarray,
                       frame: np.ndarray, name: str,
                       variables: bool = False) -> tuple[list[Path], dict, dict]:
    """A KUKA KRL program visiting joints ``q`` ``(N, 6)`` (rad) of ``nominal`` with TCP ``tool``
    in ``frame`` (4x4, m): :func:`robocal.programs.simulate.write_program`."""
    P, cfg = program_poses(d, nominal, q, tool, frame)
    p_mm = P[:, :3, 3] * 1e3
    n = len(q)
    abc = zyx_angles(P[:, :3, :3])
    src = [f"DEF {name}( )", "  $TOOL = TOOL_DATA[1]", "  $BASE = BASE_DATA[1]"]
    src += [f"  {'PTP' if i % 5 == 0 else 'LIN'} XP{i}" for i in range(n)] + ["END", ""]
    dat = [f"DEFDAT {name}"] + [
        f"DECL E6POS XP{i}={{X {p_mm[i, 0]:.3f},Y {p_mm[i, 1]:.3f},Z {p_mm[i, 2]:.3f},A {abc[i, 0]:.3f},"
        f"B {abc[i, 1]:.3f},C {abc[i, 2]:.3f},S {cfg[i, 0]},T {cfg[i, 1]},E1 0.0,E2 0.0}}"
        for i in range(n)]
    dat += ["ENDDAT", ""]
    paths = [folder / f"{name}.src", folder / f"{name}.dat"]
    paths[0].write_text("\n".join(src))
    paths[1].write_text("\n".join(dat))
    return paths, {"1": frame_text(tool, "zyx")}, {"1": frame_text(frame, "zyx")}
