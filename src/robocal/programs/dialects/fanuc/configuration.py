"""FANUC TP's configuration data (CONFIG) (:mod:`robocal.programs.config`)."""

from __future__ import annotations

import numpy as np

from robocal.ik.scara import branch_slot, first_axis, is_scara
from robocal.programs.config import ConfigScheme, branch_bits, floor_div

SCARA = -1  # the middle fields of a SCARA's row: its CONFIG has one letter, 'L|R, t1, t2, t4'


class FANUCConfig(ConfigScheme):
    """FANUC CONFIG 'F|N U|D T|B, t1, t4, t6': flip (J5 > 0), elbow down, back (wrist centre
    behind J1), and the turn numbers of J1, J4, J6 (0 for -180..180 deg, 1 for 180..540 ...).

    A SCARA's (FANUC SR-series) CONFIG is 'L|R, t1, t2, t4': the arm's hand and three turn numbers,
    here those of J1, J2 and J4 (the joints that turn; an assumption: FANUC's manuals were not at
    hand; on SR arms J1 and J2 stay within +-180 deg, so only J4's turn can differ from 0, and a
    public SR-6iA register file shows 'R, 0, 0, -1': the last field is the one that turns).
    Its row is ``[right, SCARA, SCARA, t1, t2, t4]``; right-handed ('R') is the elbow bent to the
    left looking down the arm from the shoulder (the elbow's turn positive about the base frame's
    z axis, up), so the elbow lies to the right of the line from J1 to the quill."""

    name = "FANUC CONFIG"  # rows [flip, down, back, turn1, turn4, turn6]
    branch_fields = 3

    def encode(self, robot, q):
        q = np.asarray(q, float)
        if is_scara(robot):
            right = (branch_slot(robot, q) == 0) == (_axis_up(robot) > 0)
            turns = floor_div(q[..., [0, 1, 3]], 2 * np.pi, np.pi)
            middle = np.full(q.shape[:-1] + (2,), SCARA)
            return np.concatenate([right[..., None].astype(int), middle, turns], axis=-1)
        shoulder, elbow, _ = branch_bits(robot, q)
        turns = floor_div(q[..., [0, 3, 5]], 2 * np.pi, np.pi)
        bits = np.stack([q[..., 4] > 0, elbow, shoulder], axis=-1).astype(int)
        return np.concatenate([bits, turns], axis=-1)

    def mismatch(self, robot, row):
        scara_row, scara_robot = int(row[1]) == SCARA, is_scara(robot)
        if scara_row == scara_robot:
            return ""
        return (f"CONFIG '{self.text(row)}' is a {'SCARA' if scara_row else '6-axis arm'}'s, but the "
                f"nominal model {robot.name} is {'not a SCARA' if scara_row else 'a SCARA'}: give the "
                "program's robot")

    def text(self, row):
        f, d, b, t1, t4, t6 = (int(v) for v in row)
        if d == SCARA:
            return f"{'R' if f else 'L'}, {t1}, {t4}, {t6}"
        return f"{'F' if f else 'N'} {'D' if d else 'U'} {'B' if b else 'T'}, {t1}, {t4}, {t6}"


def _axis_up(robot) -> float:
    """Cosine between a SCARA's joint-1 axis and its base frame's z axis (up)."""
    return float(first_axis(robot) @ robot.base[:3, 2])
