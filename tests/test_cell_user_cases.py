"""A new user's and a tester's cases on work cells (issue 45): each test reproduces a defect found
by following docs/how-to/cell.md on cells of other families (KUKA + DKP-400, Yaskawa + MOTOPOS,
FANUC + turntable, two ABB arms + IRBP, a headstock on a slide, a 3-axis positioner) or by fuzzing
the cell inputs, and checks its fix."""
from __future__ import annotations

import numpy as np
from cells import two_axis_cell

import robocal as rc
from robocal.kinematics.transforms import make_transform


def test_compensate_summary_does_not_count_unreached_targets_as_corrections():
    """A target out of the arm's reach is not corrected: its shift is the solver's miss (150 mm on
    the how-to's cell), and the summary named it "corrections up to 172 mm" for targets "reached by
    arm". Only reached targets' corrections are figures; the unreached are counted."""
    cell = two_axis_cell(nests=True)
    targets = make_transform(np.diag([1.0, -1.0, -1.0]), [0.0, 0.0, 0.2])[None].repeat(2, 0)
    targets[1, :3, 3] = [0.0, 0.0, 3.0]  # 3 m above the plate: out of reach
    comp = rc.compensate(cell, cell, targets, positioner_values=np.zeros((2, 2)))
    assert comp.arm_compensation.converged.tolist() == [True, False]
    text = comp.summary()
    assert "1 reached" in text and "1 not reached" in text
    assert "corrections up to 0.0000 mm" in text  # the reached target on the nominal cell: none
    none = rc.compensate(cell, cell, targets[1:], positioner_values=np.zeros((1, 2)))
    assert "0 reached; none corrected" in none.summary()
