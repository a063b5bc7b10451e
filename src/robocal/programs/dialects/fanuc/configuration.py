"""FANUC TP's configuration data (CONFIG) (:mod:`robocal.programs.config`)."""

from __future__ import annotations

import numpy as np

from robocal.programs.config import ConfigScheme, branch_bits, floor_div


class FANUCConfig(ConfigScheme):
    """FANUC CONFIG 'F|N U|D T|B, t1, t4, t6': flip (J5 > 0), elbow down, back (wrist centre
    behind J1), and the turn numbers of J1, J4, J6 (0 for -180..180 deg, 1 for 180..540 ...)."""

    name = "FANUC CONFIG"  # rows [flip, down, back, turn1, turn4, turn6]
    branch_fields = 3

    def encode(self, robot, q):
        q = np.asarray(q, float)
        shoulder, elbow, _ = branch_bits(robot, q)
        turns = floor_div(q[..., [0, 3, 5]], 2 * np.pi, np.pi)
        bits = np.stack([q[..., 4] > 0, elbow, shoulder], axis=-1).astype(int)
        return np.concatenate([bits, turns], axis=-1)

    def text(self, row):
        f, d, b, t1, t4, t6 = (int(v) for v in row)
        return f"{'F' if f else 'N'} {'D' if d else 'U'} {'B' if b else 'T'}, {t1}, {t4}, {t6}"
