"""Staubli VAL3's configuration data: a point's ``config`` (shoulder, elbow, wrist words;
:mod:`robocal.programs.config`)."""

from __future__ import annotations

import numpy as np

from robocal.programs.config import ConfigScheme, branch_bits

SHOULDER = {"lefty": 0, "righty": 1}
ELBOW = {"epositive": 0, "enegative": 1}
WRIST = {"wpositive": 0, "wnegative": 1}
CONFIG_WORDS = (("shoulder", SHOULDER), ("elbow", ELBOW), ("wrist", WRIST))


class StaubliConfig(ConfigScheme):
    """VAL3 ``config``: shoulder righty (the wrist centre behind axis 1), elbow enegative (the
    elbow bent the other way than the stretched arm), wrist wnegative (joint 5 negative); -1 in
    a wanted row (``ssame``, ``sfree``, absent) accepts either."""

    name = "VAL3 config"  # rows [righty, enegative, wnegative]
    branch_fields = 3

    def encode(self, robot, q):
        q = np.asarray(q, float)
        shoulder, elbow, _ = branch_bits(robot, q)
        return np.stack([shoulder, elbow, q[..., 4] < 0], axis=-1).astype(int)

    def score(self, have, want):
        return 1000 * ((have != want) & (want >= 0)).sum(axis=-1)

    def text(self, row):
        return " ".join(words_of(row))


def words_of(row) -> list[str]:
    out = []
    for (kind, words), v in zip(CONFIG_WORDS, row, strict=True):
        out.append(next((w for w, k in words.items() if k == int(v)), kind[0] + "free"))
    return out
