"""Rotation notations of robot programs, vectorised, each read back in the form nearest to
the numbers a file already holds (so an unchanged pose keeps its numbers).

* quaternion w-first (ABB): the sign nearest the old quaternion;
* ZYX Euler ``R = Rz(a) Ry(b) Rx(c)`` in deg (KUKA A, B, C; FANUC W, P, R is the same matrix
  with (a, b, c) = (R, P, W); scipy's ``Rotation.from_euler("ZYX", (a, b, c), degrees=True)``
  reads them): of the two solutions the one nearest the old angles, each angle in [-180, 180];
  within ``GIMBAL`` of b = +-90 deg, a keeps its old value. Near b = +-90 deg a tiny turn moves a
  and c far (a tilt of 0.0005 deg off the pole can swing them by 20 deg): when keeping the old a
  (and solving b, c) represents the rotation within ``tol_deg`` (the file's resolution), that
  triple, nearest the file's numbers, is taken;
* rotation vector in rad (URScript; :func:`robocal.kinematics.transforms.rotvec_to_matrix`
  reads it): r or its 2 pi complement, whichever is nearer.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.kinematics.transforms import matrix_to_rotvec

GIMBAL = 1e-6  # |cos b| below which the ZYX Euler angles a and c are not separable


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Quaternions ``(N, 4)`` w-first (normalised here) -> ``(N, 3, 3)``."""
    return Rotation.from_quat(np.asarray(q, float), scalar_first=True).as_matrix()


def matrix_to_quat(R: np.ndarray, old: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` -> quaternions ``(N, 4)`` w-first with the sign of ``old``."""
    q = Rotation.from_matrix(R).as_quat(scalar_first=True)
    flip = np.einsum("ij,ij->i", q, old) < 0
    q[flip] *= -1
    return q


def _wrap_deg(x: np.ndarray) -> np.ndarray:
    return x - 360.0 * np.round(x / 360.0)


def _zyx(abc_deg: np.ndarray) -> np.ndarray:
    """``R = Rz(a) Ry(b) Rx(c)`` ``(N, 3, 3)`` of ZYX Euler angles ``(N, 3)`` deg."""
    return Rotation.from_euler("ZYX", abc_deg, degrees=True).as_matrix()


def _keeping_a(R: np.ndarray, a_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The ZYX triple with ``a`` fixed that comes nearest ``R`` (b, c from ``Rz(-a) R``), and how
    far it is from ``R`` (deg)."""
    a = np.deg2rad(a_deg)
    Rz = np.zeros((len(a), 3, 3))
    Rz[:, 0, 0] = Rz[:, 1, 1] = np.cos(a)
    Rz[:, 0, 1], Rz[:, 1, 0] = np.sin(a), -np.sin(a)  # Rz(-a)
    Rz[:, 2, 2] = 1.0
    P = Rz @ R  # ~ Ry(b) Rx(c)
    b = np.arctan2(-P[:, 2, 0], P[:, 0, 0])
    c = np.arctan2(-P[:, 1, 2], P[:, 1, 1])
    abc = np.stack([a_deg, np.rad2deg(b), np.rad2deg(c)], axis=1)
    off = matrix_to_rotvec(np.swapaxes(_zyx(abc), 1, 2) @ R)
    return abc, np.rad2deg(np.linalg.norm(off, axis=1))


def matrix_to_zyx(R: np.ndarray, old: np.ndarray, tol_deg: float = 0.0) -> np.ndarray:
    """``(N, 3, 3)`` -> ZYX Euler ``(N, 3)`` deg nearest ``old`` (see the module docstring);
    ``tol_deg``: how far from ``R`` a triple that keeps the old a may be (0: exact)."""
    old = np.asarray(old, float)
    exact = _exact_zyx(R, old)
    if tol_deg <= 0 or not len(R):
        return exact
    kept, off = _keeping_a(R, old[:, 0])
    kept = old + _wrap_deg(kept - old)
    use = (off <= tol_deg) & (np.abs(kept) <= 180.0).all(axis=1) & \
        (np.abs(kept - old).sum(axis=1) <= np.abs(exact - old).sum(axis=1) + tol_deg)
    return np.where(use[:, None], kept, exact)


def _exact_zyx(R: np.ndarray, old: np.ndarray) -> np.ndarray:
    """The ZYX triple of ``R`` nearest ``old`` among its two exact ones (gimbal lock: a kept)."""
    cb = np.hypot(R[:, 0, 0], R[:, 1, 0])
    b = np.arctan2(-R[:, 2, 0], cb)
    a = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    c = np.arctan2(R[:, 2, 1], R[:, 2, 2])
    one = np.rad2deg(np.stack([a, b, c], axis=1))
    two = np.stack([one[:, 0] + 180.0, 180.0 - one[:, 1], one[:, 2] + 180.0], axis=1)
    gimbal = cb < GIMBAL
    if gimbal.any():  # a keeps its old value, c takes the rest of the rotation about z
        a_old = np.deg2rad(old[gimbal, 0])
        up = -R[gimbal, 2, 0] > 0
        r01, r11 = R[gimbal, 0, 1], R[gimbal, 1, 1]
        c_g = np.where(up, a_old + np.arctan2(r01, r11), np.arctan2(-r01, r11) - a_old)
        b_g = np.where(up, 90.0, -90.0)
        one[gimbal] = two[gimbal] = np.stack([np.rad2deg(a_old), b_g, np.rad2deg(c_g)], axis=1)
    one, two = _wrap_deg(one), _wrap_deg(two)
    d1 = np.abs(_wrap_deg(one - old)).sum(axis=1)
    d2 = np.abs(_wrap_deg(two - old)).sum(axis=1)
    best = np.where((d2 < d1)[:, None], two, one)
    # the representative of each angle nearest the old number, kept inside [-180, 180]
    near = old + _wrap_deg(best - old)
    return np.where(np.abs(near) <= 180.0, near, best)


def nearest_rotvec(R: np.ndarray, old: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` -> rotation vectors ``(N, 3)`` rad, r or (|r| - 2 pi) r / |r|, nearest old."""
    r = matrix_to_rotvec(R)
    angle = np.linalg.norm(r, axis=1, keepdims=True)
    alt = r * np.where(angle > 0, (angle - 2 * np.pi) / np.where(angle > 0, angle, 1.0), 1.0)
    use_alt = np.linalg.norm(alt - old, axis=1) < np.linalg.norm(r - old, axis=1)
    return np.where(use_alt[:, None], alt, r)
