"""Simulated Staubli VAL3 programs with known truth, for tests and benchmarks
(:mod:`robocal.programs.simulate`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.kinematics.model import Robot
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.val3.configuration import words_of
from robocal.programs.dialects.writing import program_poses


def write_test_program(d: Dialect, folder: Path, nominal: Robot, q: np.ndarray, tool: np.ndarray,
                       frame: np.ndarray, name: str,
                       variables: bool = False) -> tuple[list[Path], dict, dict]:
    """A Staubli VAL3 program visiting joints ``q`` ``(N, 6)`` (rad) of ``nominal`` with TCP ``tool``
    in ``frame`` (4x4, m): :func:`robocal.programs.simulate.write_program`."""
    P, cfg = program_poses(d, nominal, q, tool, frame)
    return _application(folder, d, P, cfg, tool, frame, name)


def _application(folder: Path, d, P: np.ndarray, cfg: np.ndarray, tool: np.ndarray, frame: np.ndarray,
                 name: str):
    """A VAL3 application: points ``P`` in frame fCell, tool tReal, movel / movej to each."""

    def attrs(values) -> str:
        return " ".join(f'{k}="{v:.3f}"' if k in "xyz" else f'{k}="{v:.4f}"'
                        for k, v in zip(("x", "y", "z", "rx", "ry", "rz"), values, strict=True))

    zero = np.zeros((1, 6))
    values = d.from_pose(P, np.zeros((len(P), 6)))
    words = [words_of(row) for row in cfg]
    points = [f'      <Value key="{i}" {attrs(v)} shoulder="{w[0]}" elbow="{w[1]}" wrist="{w[2]}" '
              'fatherId="fCell[0]" />' for i, (v, w) in enumerate(zip(values, words, strict=True))]
    data = '    <Data name="{}" access="public" xsi:type="array" type="{}" size="{}">'
    cell, real = attrs(d.from_pose(frame[None], zero)[0]), attrs(d.from_pose(tool[None], zero)[0])
    dtx = ['<?xml version="1.0" encoding="utf-8"?>', '<Database xmlns:xsi="http://www.w3.org/2001/XMLSchema-'
           'instance" xmlns="http://www.staubli.com/robotics/VAL3/Data/2">', "  <Datas>",
           data.format("fCell", "frame", 1), f'      <Value key="0" {cell} fatherId="world[0]" />',
           "    </Data>", data.format("tReal", "tool", 1),
           f'      <Value key="0" {real} fatherId="flange[0]" />', "    </Data>",
           data.format("pP", "pointRx", len(P)), *points, "    </Data>", "  </Datas>", "</Database>", ""]
    moves = [f"  {'movej' if i % 5 == 0 else 'movel'}(pP[{i}], tReal, mNomSpeed)" for i in range(len(P))]
    pgx = ['<?xml version="1.0" encoding="utf-8"?>', '<Programs xmlns="http://www.staubli.com/robotics/VAL3/'
           'Program/2">', '  <Program name="start" access="public">', "    <Code><![CDATA[begin", *moves,
           "end]]></Code>", "  </Program>", "</Programs>", ""]
    paths = [folder / f"{name}.dtx", folder / "start.pgx"]
    paths[0].write_text("\r\n".join(dtx))
    paths[1].write_text("\r\n".join(pgx))
    return paths, {}, {}
