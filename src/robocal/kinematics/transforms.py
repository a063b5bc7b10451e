"""Small rigid-transform helpers on plain arrays (hot paths; scipy Rotation only at the edges)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

# Largest deviation from orthonormality (and of det from 1) of a rotation matrix that counts as a
# rotation: files give rotations to a few decimals (a quaternion to 6 digits is 1e-6 off).
ROTATION_TOL = 1e-6


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices of vectors ``(..., 3)`` -> ``(..., 3, 3)``."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def rotvec_to_matrix(rv: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation vectors ``(..., 3)`` in rad -> rotation matrices ``(..., 3, 3)``."""
    rv = np.asarray(rv, dtype=float)
    angle = np.linalg.norm(rv, axis=-1)[..., None, None]
    K = skew(rv)
    small = angle < 1e-8
    safe = np.where(small, 1.0, angle)
    a = np.where(small, 1.0 - angle**2 / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - angle**2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    return np.eye(3) + a * K + b * (K @ K)


def matrix_to_rotvec(R: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` -> rotation vectors ``(..., 3)`` (rad), valid up to pi."""
    R = np.asarray(R, dtype=float)
    flat = R.reshape(-1, 3, 3)
    return Rotation.from_matrix(flat).as_rotvec().reshape(R.shape[:-2] + (3,))


def nearest_rotation(M: np.ndarray) -> np.ndarray:
    """The rotation ``(3, 3)`` nearest a matrix ``M (3, 3)`` in the Frobenius norm (its SVD with the
    last singular direction flipped when ``det(U Vt) < 0``): the projection every frame fit here uses
    (a mean of rotations, Kabsch/Umeyama ``nearest_rotation(H).T`` for a cross-covariance ``H``)."""
    U, _, Vt = np.linalg.svd(M)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0])
    return U @ D @ Vt


def kabsch_rotation(H: np.ndarray) -> np.ndarray:
    """The rotation ``R (3, 3)`` that best turns the source points onto the destination points of a
    cross-covariance ``H = sum (src - cs)(dst - cd)^T`` (Kabsch / Umeyama: ``V D U^T`` from the SVD
    ``H = U S V^T``, ``D`` flipping the last direction of a reflection). The same rotation as
    ``nearest_rotation(H).T``, computed in the order the frame fits were written in (their
    results, bit for bit)."""
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0])
    return Vt.T @ D @ U.T


def make_transform(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Homogeneous transforms ``(..., 4, 4)`` from rotations ``(..., 3, 3)`` and translations."""
    R = np.asarray(R, dtype=float)
    t = np.asarray(t, dtype=float)
    shape = np.broadcast_shapes(R.shape[:-2], t.shape[:-1])
    T = np.zeros(shape + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points ``(k, 3)`` given in a frame, expressed in the frame ``T`` ``(4, 4)`` is given in:
    ``R p + t`` for each (m)."""
    return points @ T[:3, :3].T + T[:3, 3]


def invert_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms ``(..., 4, 4)``."""
    R = T[..., :3, :3]
    Rt = np.swapaxes(R, -1, -2)
    return make_transform(Rt, -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3]))


def pose_error(T_measured: np.ndarray, T_model: np.ndarray) -> np.ndarray:
    """6-vector errors ``(..., 6)``: position difference and the rotation vector of R_meas R_model^T.

    Both in the world frame, so they match the identification Jacobian's rows.
    """
    dp = T_measured[..., :3, 3] - T_model[..., :3, 3]
    dR = T_measured[..., :3, :3] @ np.swapaxes(T_model[..., :3, :3], -1, -2)
    return np.concatenate([dp, matrix_to_rotvec(dR)], axis=-1)


def rotation_fault(R: np.ndarray, tol: float = ROTATION_TOL) -> str | None:
    """What keeps a ``(3, 3)`` matrix from being a rotation (to ``tol``): ``"a mirror (det -1)"``,
    ``"not orthonormal (a shear or a scale)"``, ``"not finite"``; None for a proper rotation. Every
    frame a file or a caller gives (a model's base and tool, a cell's mount, plate, flange) is
    checked with it.

    Examples
    --------
    >>> import numpy as np
    >>> from robocal.kinematics.transforms import rotation_fault
    >>> rotation_fault(np.eye(3)) is None, rotation_fault(np.diag([1.0, 1.0, -1.0]))
    (True, 'a mirror (det -1)')
    """
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3) or not np.isfinite(R).all():
        return "not finite"
    if np.abs(R @ R.T - np.eye(3)).max() > tol:
        return "not orthonormal (a shear or a scale)"
    if abs(np.linalg.det(R) - 1) > tol:
        return "a mirror (det -1)"
    return None


def is_rigid(T: np.ndarray, tol: float = ROTATION_TOL) -> np.ndarray:
    """Whether each ``(..., 4, 4)`` matrix is a proper rigid transform (to ``tol``)."""
    T = np.asarray(T, dtype=float)
    c = [T[..., :3, k] for k in range(3)]  # rotation columns
    ortho = np.zeros(T.shape[:-2])
    for i in range(3):
        for j in range(i, 3):
            dot = np.einsum("...k,...k->...", c[i], c[j])
            ortho = np.maximum(ortho, np.abs(dot - (i == j)))
    det = np.einsum("...k,...k->...", np.cross(c[0], c[1]), c[2])
    last = np.abs(T[..., 3, :] - np.array([0.0, 0.0, 0.0, 1.0])).max(axis=-1)
    with np.errstate(invalid="ignore"):  # NaN compares False below: not rigid
        return (ortho < tol) & (np.abs(det - 1.0) < tol) & (last < tol) & np.isfinite(T).all(axis=(-1, -2))


def rot_x(t: float) -> np.ndarray:
    """The rotation ``(3, 3)`` by ``t`` rad about x."""
    c, s = np.cos(t), np.sin(t)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(t: float) -> np.ndarray:
    """The rotation ``(3, 3)`` by ``t`` rad about y."""
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def rot_z(t: float) -> np.ndarray:
    """The rotation ``(3, 3)`` by ``t`` rad about z."""
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
