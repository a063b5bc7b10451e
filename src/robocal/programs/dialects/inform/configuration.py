"""Yaskawa INFORM's configuration data: the form (RCONF) of a position (:mod:`robocal.programs.config`)."""

from __future__ import annotations

import numpy as np

from robocal.programs.config import ConfigScheme, branch_bits

TURN_TOLERANCE = 1e-12  # relative: an angle printed as exactly 180 deg keeps its R, T, S flag


class YaskawaConfig(ConfigScheme):
    """Yaskawa's form (RCONF) ``l, m, n, o, p, q, ...``: l = 1 no flip (B < 0), 0 flip; m = 1 lower
    arm (the elbow bent the other way than in the zero pose), 0 upper arm; n = 1 back (the wrist
    centre behind the S axis), 0 front; o, p, q = 1 when R, T, S stand at 180 deg or more
    (outside -180 < angle <= 180), else 0. Rows carry 2 for an angle beyond +-360 deg (written as
    1), so that a flag 1 selects the copy within +-360 deg before one beyond it (a T axis of
    +-455 deg has two copies with the flag set)."""

    name = "Yaskawa RCONF"  # rows [no_flip, lower, back, R, T, S]: 0 | 1 | 2 (beyond a turn)
    branch_fields = 3

    def encode(self, robot, q):
        q = np.asarray(q, float)
        shoulder, elbow, _ = branch_bits(robot, q)
        a = q[..., [3, 5, 0]]
        half, turn = np.pi * (1 + TURN_TOLERANCE), 2 * np.pi * (1 + TURN_TOLERANCE)
        over = (~((a > -half) & (a <= half))).astype(int) + (~((a > -turn) & (a <= turn))).astype(int)
        bits = np.stack([q[..., 4] < 0, elbow, shoulder], axis=-1).astype(int)
        return np.concatenate([bits, over], axis=-1)

    def text(self, row):
        return ",".join(str(min(int(v), 1)) for v in row)
