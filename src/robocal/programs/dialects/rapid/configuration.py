"""ABB RAPID's configuration data (confdata) (:mod:`robocal.programs.config`)."""

from __future__ import annotations

import numpy as np

from robocal.programs.config import BRANCH_MISMATCH, ConfigScheme, branch_bits, floor_div, set_bits


class ABBConfig(ConfigScheme):
    """ABB confdata [cf1, cf4, cf6, cfx]: quadrants floor(q / 90 deg) of axes 1, 4, 6 and
    cfx = 4 * behind axis 1 + 2 * behind the lower arm + (axis 5 negative)."""

    name = "ABB confdata"  # rows [cfx, cf1, cf4, cf6]
    branch_fields = 1

    def encode(self, robot, q):
        q = np.asarray(q, float)
        shoulder, elbow, _ = branch_bits(robot, q)
        cfx = 4 * shoulder.astype(int) + 2 * elbow.astype(int) + (q[..., 4] < 0).astype(int)
        quad = floor_div(q[..., [0, 3, 5]], np.pi / 2)
        return np.concatenate([cfx[..., None], quad], axis=-1)

    def score(self, have, want):
        # cfx compared bit by bit
        bits = set_bits(np.bitwise_xor(have[..., 0], want[..., 0]), 3)
        return BRANCH_MISMATCH * bits + np.abs(have[..., 1:] - want[..., 1:]).sum(axis=-1)

    def text(self, row):
        return f"[{int(row[1])},{int(row[2])},{int(row[3])},{int(row[0])}]"
