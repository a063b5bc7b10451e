"""Configuration data <-> the closed-form branch slot and the +-2 pi turn of each joint: what
every language's configuration scheme (``dialects/<language>/configuration.py``) shares.

The branch slot of :func:`robocal.ik.solve_all` is ``s = 4 * wrist_flip + 2 * shoulder + elbow``
(see :mod:`robocal.ik.opw_ik`). :func:`branch_bits` computes the three bits of any joint vector
from the OPW paper angles ``theta = q * sign - offset`` of the nominal model:

* shoulder 1: the wrist centre is behind the axis of joint 1 (its x in the frame that turns
  with joint 1 is negative): ABB cfx "behind axis 1", KUKA S bit 0 "overhead area", FANUC "B";
* elbow 1: the elbow angle theta3 + psi3 is negative, the arm bent the other way than in the
  zero pose of every vendor (elbow up): ABB cfx "wrist centre behind the lower arm", KUKA S
  bit 1 = 0 ("A3 < phi"), FANUC "D";
* the wrist is read from the vendor's own joint 5 sign (ABB cfx bit 0: axis 5 negative, KUKA S
  bit 2: A5 <= 0, FANUC "F": J5 > 0).

Each scheme turns joints ``(..., 6)`` into integer configuration rows and scores how far a
candidate's row is from the one a target asks for: ``BRANCH_MISMATCH`` per differing branch
bit plus the turn (quadrant, turn number, sign bit) mismatches. The candidate with the lowest
score is what the vendor's controller would choose.
"""

from __future__ import annotations

import numpy as np

from robocal.ik.opw_ik import branch_bits as opw_branch_bits
from robocal.ik.opw_ik import opw_form
from robocal.kinematics.model import Robot

BRANCH_MISMATCH = 1000  # score of one differing branch bit: always worse than any turn mismatch


def branch_bits(robot: Robot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(shoulder, elbow, flip)`` bool arrays of joints ``(..., 6)`` (rad) on ``robot``'s OPW
    form (the nominal one a calibrated model carries): :func:`robocal.ik.opw_ik.branch_bits`."""
    return opw_branch_bits(robot.opw if robot.opw is not None else opw_form(robot), q)


def set_bits(x: np.ndarray, n: int) -> np.ndarray:
    """How many of the lowest ``n`` bits of integers ``x`` are set."""
    return sum((x >> i) & 1 for i in range(n))


def floor_div(q: np.ndarray, step: float, shift: float = 0.0) -> np.ndarray:
    # a hair of tolerance so that values printed as exactly 90.000 deg stay in their quadrant
    return np.floor((q + shift) / step + 1e-12).astype(int)


class ConfigScheme:
    """A vendor's configuration data: :meth:`encode` joints -> int rows, :meth:`score` candidate
    rows against wanted rows, :meth:`text` for messages."""

    name = ""
    branch_fields = 0  # the first fields that select the branch; the rest select turns

    def encode(self, robot: Robot, q: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def score(self, have: np.ndarray, want: np.ndarray) -> np.ndarray:
        """``(...)`` mismatch of candidate rows ``have`` ``(..., m)`` against ``want``."""
        b = self.branch_fields
        return (BRANCH_MISMATCH * (have[..., :b] != want[..., :b]).sum(axis=-1)
                + np.abs(have[..., b:] - want[..., b:]).sum(axis=-1))

    def text(self, row) -> str:
        return "[" + ",".join(str(int(v)) for v in row) + "]"

    def mismatch(self, robot: Robot, row) -> str:
        """Why configuration data ``row`` cannot describe any joints of ``robot`` (another kind of
        arm's), or '' when it can."""
        return ""
