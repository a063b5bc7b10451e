"""Cells the cell tests share: an arm and a 2-axis tilt-and-turn positioner."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

import robocal as rc
from robocal.kinematics.transforms import make_transform


def two_axis_cell():
    """abb_irb2600 at the world origin and a tilt (about world x, 900 mm up) and turn table 1.4 m in front."""
    arm = rc.Robot.from_catalog("abb_irb2600")
    mount = make_transform(np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]), [1.4, 0.0, 0.9])
    chain = rc.Robot.from_mdh(alpha=[0, 90], a=[0, 0], theta=[0, 0], d=[0, 0.25], degrees=True,
                              limits=[[-90, 90], [-360, 360]], base=mount, name="tilt-turn")
    positioner = SimpleNamespace(chain=chain, columns=("e1", "e2"), unit="STN1", nests=None)
    return SimpleNamespace(arms={"arm": arm}, positioners={"STN1": positioner}, anchor="arm")
