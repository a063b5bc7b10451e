"""KUKA KRL's configuration data (Status and Turn) (:mod:`robocal.programs.config`)."""

from __future__ import annotations

import numpy as np

from robocal.programs.config import BRANCH_MISMATCH, ConfigScheme, branch_bits, set_bits


class KUKAConfig(ConfigScheme):
    """KUKA Status and Turn: S bit 0 overhead area, bit 1 A3 >= phi (elbow as in the zero
    pose), bit 2 A5 <= 0; T bit i set when axis i+1 is negative."""

    name = "KUKA S/T"  # rows [S, T]

    def encode(self, robot, q):
        q = np.asarray(q, float)
        shoulder, elbow, _ = branch_bits(robot, q)
        S = shoulder.astype(int) + 2 * (~elbow).astype(int) + 4 * (q[..., 4] <= 0).astype(int)
        T = ((q < 0).astype(int) << np.arange(q.shape[-1])).sum(axis=-1)
        return np.stack([S, T], axis=-1)

    def score(self, have, want):
        # T = -1: the target gives no turn, any turn will do
        ds = np.bitwise_xor(have[..., 0], want[..., 0] & 7)
        dt = np.where(want[..., 1] < 0, 0, np.bitwise_xor(have[..., 1], want[..., 1] & 63))
        return BRANCH_MISMATCH * set_bits(ds, 3) + set_bits(dt, 6)

    def text(self, row):
        return f"S {int(row[0])} T {int(row[1])}"
