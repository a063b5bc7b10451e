"""ISO 9283-style pose accuracy (AP) and pose repeatability (RP) from repeated measurements.

Rows that share a pose id, the same joints and the same SMR are repeated measurements of one
commanded pose. For a group of n >= 2 measured positions P_j with barycentre G and commanded
position C (the calibrated model's prediction for those joints):

    AP = |G - C|,  (APx, APy, APz) = G - C
    l_j = |P_j - G|,  l_bar = mean(l_j),  S_l = sqrt(sum (l_j - l_bar)^2 / (n - 1))
    RP = l_bar + 3 S_l

(ISO 9283:1998, 7.2.1 and 7.2.2; the standard asks for 30 cycles, we use what the data has).
Units are those of the inputs (the report passes mm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PoseGroups:
    """Per commanded pose (m groups of at least two measurements): the statistics above.

    ``pose_id`` ``(m,)``, ``n`` ``(m,)`` measurements, ``barycentre`` and ``commanded``
    ``(m, 3)``, ``ap_xyz`` ``(m, 3)``, ``ap``, ``l_mean``, ``s_l``, ``rp`` ``(m,)``;
    ``rows`` ``(N,)`` gives each input row's group index (-1 for a single measurement).
    """

    pose_id: np.ndarray
    n: np.ndarray
    barycentre: np.ndarray
    commanded: np.ndarray
    ap_xyz: np.ndarray
    ap: np.ndarray
    l_mean: np.ndarray
    s_l: np.ndarray
    rp: np.ndarray
    rows: np.ndarray

    def __len__(self) -> int:
        return self.n.size


def group_repeats(pose_id, joints, smr=None, decimals: int = 9) -> np.ndarray:
    """Group index ``(N,)`` of rows with the same pose id, joints (rounded to ``decimals``) and
    SMR; rows measured only once get -1, groups are numbered 0..m-1 in order of first row."""
    pose_id = np.asarray(pose_id).reshape(-1)
    joints = np.round(np.asarray(joints, dtype=float).reshape(pose_id.size, -1), decimals)
    smr = np.zeros(pose_id.size) if smr is None else np.asarray(smr, dtype=float).reshape(-1)
    key = np.column_stack([pose_id.astype(float), smr, joints])
    _, first, inverse, counts = np.unique(key, axis=0, return_index=True, return_inverse=True,
                                          return_counts=True)
    inverse = inverse.reshape(-1)
    repeated = counts >= 2
    order = np.argsort(first[repeated], kind="stable")
    new_index = np.full(counts.size, -1)
    new_index[np.flatnonzero(repeated)[order]] = np.arange(order.size)
    return new_index[inverse]


def pose_accuracy_repeatability(measured, commanded, pose_id, joints, smr=None) -> PoseGroups:
    """AP and RP of every repeated commanded pose.

    ``measured`` and ``commanded`` ``(N, 3)`` positions (same unit), ``pose_id`` ``(N,)``,
    ``joints`` ``(N, n)``, optional ``smr`` ``(N,)``. The commanded position of a group is the
    mean of its rows' ``commanded`` (they are equal for equal joints).
    """
    measured = np.asarray(measured, dtype=float).reshape(-1, 3)
    commanded = np.asarray(commanded, dtype=float).reshape(-1, 3)
    rows = group_repeats(pose_id, joints, smr)
    m = int(rows.max()) + 1 if rows.size else 0
    sel = rows >= 0
    g = rows[sel]
    n = np.bincount(g, minlength=m).astype(float)
    sums = np.zeros((m, 3))
    np.add.at(sums, g, measured[sel])
    bary = sums / n[:, None] if m else sums
    csum = np.zeros((m, 3))
    np.add.at(csum, g, commanded[sel])
    cmd = csum / n[:, None] if m else csum
    dist = np.linalg.norm(measured[sel] - bary[g], axis=1)
    l_mean = np.bincount(g, weights=dist, minlength=m) / np.maximum(n, 1)
    var = np.bincount(g, weights=(dist - l_mean[g]) ** 2, minlength=m) / np.maximum(n - 1, 1)
    s_l = np.sqrt(var)
    ap_xyz = bary - cmd
    first = np.zeros(m, dtype=int)
    idx = np.flatnonzero(sel)
    first[g[::-1]] = idx[::-1]
    pid = np.asarray(pose_id).reshape(-1)[first] if m else np.zeros(0, dtype=int)
    return PoseGroups(pose_id=pid, n=n.astype(int), barycentre=bary, commanded=cmd, ap_xyz=ap_xyz,
                      ap=np.linalg.norm(ap_xyz, axis=1), l_mean=l_mean, s_l=s_l,
                      rp=l_mean + 3.0 * s_l, rows=rows)
