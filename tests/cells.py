"""Cells the cell tests share: an arm and a 2-axis tilt-and-turn positioner."""

from __future__ import annotations

import numpy as np

import robocal as rc
from robocal.kinematics.positioner import positioner_chain
from robocal.kinematics.transforms import make_transform

TILT_TURN = [  # limits rad
    {"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 0.7], "limits": [-np.pi / 2, np.pi / 2]},
    {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.25], "limits": [-np.pi, np.pi]}]
NESTS = np.array([[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [-0.15, -0.15, 0.0]])  # m, plate frame


def two_axis_cell(nests: bool = False, arm: str = "abb_irb2600") -> rc.Cell:
    """``arm`` at the world origin and a tilt (about world x, 700 mm up) and turn table 1.1 m in
    front (the plate 250 mm above the tilt axis), with three nests on the plate or none."""
    chain = positioner_chain(TILT_TURN, make_transform(np.eye(3), [1.1, 0.0, 0.0]), name="tilt-turn")
    positioner = rc.Positioner(chain, unit="STN1", nests=NESTS if nests else None)
    return rc.Cell({"arm": rc.Robot.from_catalog(arm)}, {"STN1": positioner}, name="test cell")
