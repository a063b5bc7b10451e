"""Data fingerprints: which poses two measurement sets share.

A pose is its joint vector. Two rows are the *same pose* when every joint agrees within
:data:`JOINT_REPEAT_TOL_DEG` (a pose measured again reads the same joints up to encoder noise; a
different pose of a campaign differs by degrees). A validation set that repeats calibration poses
says nothing about the accuracy elsewhere: the repeated rows are left out of the held-out figure.
"""

from __future__ import annotations

import hashlib

import numpy as np
from scipy.spatial import cKDTree

from robocal.core.errors import DataError
from robocal.kinematics.model import joints_in_units

JOINT_REPEAT_TOL_DEG = 0.01  # every joint within this: the same pose (joint reading noise)
_FINGERPRINT_DECIMALS = 4  # joints (deg) are rounded to this many decimals before hashing


def fingerprint(joints: np.ndarray) -> str:
    """A short hex digest (16 characters) of a set of joint vectors ``(N, n)`` (rad), in row order:
    the same poses in the same order give the same fingerprint."""
    q = np.round(np.rad2deg(np.asarray(joints, dtype=float)), _FINGERPRINT_DECIMALS) + 0.0  # no -0.0
    h = hashlib.sha256(np.ascontiguousarray(q).tobytes())
    h.update(str(q.shape).encode())
    return h.hexdigest()[:16]


def repeated_rows(reference: np.ndarray, joints: np.ndarray, tol_deg: float = JOINT_REPEAT_TOL_DEG,
                  prismatic: np.ndarray | None = None) -> np.ndarray:
    """``(N,)`` bool: which rows of ``joints (N, n)`` (rad; m on a joint flagged in ``prismatic
    (n,)``) repeat a pose of ``reference (M, n)``: every joint within ``tol_deg`` (a prismatic
    joint within ``tol_deg`` mm)."""
    reference, joints = np.asarray(reference, float), np.asarray(joints, float)
    if len(reference) == 0 or len(joints) == 0:
        return np.zeros(len(joints), bool)
    if prismatic is not None and np.any(prismatic):  # each joint in its unit: deg, mm
        dist, _ = cKDTree(joints_in_units(reference, prismatic)).query(
            joints_in_units(joints, prismatic), p=np.inf, distance_upper_bound=tol_deg)
    else:
        dist, _ = cKDTree(reference).query(joints, p=np.inf, distance_upper_bound=np.deg2rad(tol_deg))
    return np.isfinite(dist)


def tolerance_unit(data) -> str:
    """The unit `repeated_rows`' tolerance is in for ``data``: ``deg``, or ``deg (mm on a
    prismatic joint)``."""
    return "deg" if data.linear is None else "deg (mm on a prismatic joint)"


def independent(data, reference: list, what: str):
    """``data`` (Measurements) without the rows that repeat a pose of the ``reference`` sets
    (:func:`repeated_rows`; a distance pair goes whole), and how many rows were dropped.
    DataError naming ``what`` when every row repeats one."""
    ref = [d.joints for d in reference if d.n_joints == data.n_joints]
    mask = repeated_rows(np.vstack(ref), data.joints, prismatic=data.linear) if ref else \
        np.zeros(len(data), bool)
    if data.pair is not None:
        mask = np.isin(data.pair, data.pair[mask])
    if mask.all():
        raise DataError(f"{what}: every one of its {len(data)} rows repeats a calibration pose (joints "
                        f"within {JOINT_REPEAT_TOL_DEG:g} {tolerance_unit(data)}): judged on the "
                        "calibration's own poses it says nothing of the accuracy elsewhere; validate on "
                        "poses measured apart from the calibration")
    return (data.subset(np.flatnonzero(~mask)) if mask.any() else data), int(mask.sum())
