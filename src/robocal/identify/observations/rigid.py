"""Rigid frames estimated with the robot as nuisance parameters, and their starting values.

The instrument kinds (markers, cameras) carry frames the robot model does not: the capture or
camera frame, a board, a marker's offset on its link. Each frame is six nuisance parameters
``(x, y, z, rx, ry, rz)`` about a reference ``T0`` fixed when the observation is built:
``T(nu) = [Rot(nu_r) R0, t0 + nu_t]`` (``Rot``: Rodrigues). A step ``delta`` of ``nu_r`` turns the
frame by the world-frame rotation vector ``J_l(nu_r) delta`` (:func:`left_jacobian`), so the
Jacobians below are exact at any ``nu``, not only at 0.

Starting values: :func:`hand_eye` solves ``C_i = L A_i R`` for the two fixed frames L and R from
the measured ``C_i`` and the modelled ``A_i`` (Park & Martin, "Robot sensor calibration: solving
AX = XB on the Euclidean group", IEEE Trans. Robot. Autom. 10(5):717-721, 1994: rotation from the
relative motions' axes by an SVD, translation by linear least squares), then ``L`` as the chordal
mean of ``C_i R^-1 A_i^-1``.
"""

from __future__ import annotations

import numpy as np

from robocal.core.errors import IdentificationError
from robocal.kinematics.transforms import (
    invert_transform,
    kabsch_rotation,
    make_transform,
    matrix_to_rotvec,
    nearest_rotation,
    rotvec_to_matrix,
    skew,
)

SMALL_ANGLE = 1e-8  # rad: below it the left Jacobian's series is used
# relative rotations smaller than this (rad) carry no direction for the hand-eye rotation
MIN_RELATIVE_TURN = 1e-3
FRAME_FIELDS = ("x", "y", "z", "rx", "ry", "rz")
FRAME_PREFIXES = ("base.", "tool.", "smr")  # robot frames an instrument's own frames replace


def replaced_frames(robot) -> list[str]:
    """Robot parameters an instrument with its own frames (a capture frame and marker offsets, a
    camera's and a board's frames) never identifies apart from them: the base and tool frames and
    the SMR offsets."""
    return [n for n in robot.parameter_names if n.startswith(FRAME_PREFIXES)]


def left_jacobian(phi: np.ndarray) -> np.ndarray:
    """SO(3) left Jacobian ``(3, 3)`` of the rotation vector ``phi (3,)``:
    ``Rot(phi + d) = Rot(J_l d) Rot(phi)`` to first order in ``d``."""
    angle = float(np.linalg.norm(phi))
    K = skew(phi)
    if angle < SMALL_ANGLE:
        return np.eye(3) + K / 2 + K @ K / 6
    return (np.eye(3) + (1 - np.cos(angle)) / angle**2 * K
            + (angle - np.sin(angle)) / angle**3 * (K @ K))


def frame_of(T0: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """The frame ``(..., 4, 4)`` of nuisance values ``nu (..., 6)`` about ``T0 (4, 4)``."""
    nu = np.asarray(nu, float)
    return make_transform(rotvec_to_matrix(nu[..., 3:]) @ T0[:3, :3], T0[:3, 3] + nu[..., :3])


def nuisance_of(T0: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``(6,)`` nuisance values that give frame ``T`` about ``T0`` (inverse of :func:`frame_of`)."""
    return np.r_[T[:3, 3] - T0[:3, 3], matrix_to_rotvec(T[:3, :3] @ T0[:3, :3].T)]


def chordal_mean(T: np.ndarray) -> np.ndarray:
    """The rigid transform ``(4, 4)`` closest to frames ``T (N, 4, 4)``: mean translation, and the
    rotation nearest the mean rotation matrix (SVD projection)."""
    return make_transform(nearest_rotation(T[:, :3, :3].mean(axis=0)), T[:, :3, 3].mean(axis=0))


def _pairs(N: int) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs ``(i, j)`` of relative motions: each row with the one N // 2 rows on (a wide
    spread of motions, N pairs, no N^2 set)."""
    i = np.arange(N)
    return i, (i + max(N // 2, 1)) % N


def hand_eye(A: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(L, R)`` with ``C_i ~ L A_i R`` for frames ``A, C (N, 4, 4)`` (see the module).

    Raises
    ------
    IdentificationError
        Fewer than 3 rows, or motions that turn about one axis only (the hand-eye rotation is then
        not determined: measure poses that turn the wrist about different axes).
    """
    N = A.shape[0]
    if N < 3:
        raise IdentificationError(f"{N} poses cannot fix a camera's and a board's frames: measure at least 3 "
                                  "(20 or more is better)")
    i, j = _pairs(N)
    RA = invert_transform(A[i]) @ A[j]
    RB = invert_transform(C[i]) @ C[j]
    alpha, beta = matrix_to_rotvec(RA[:, :3, :3]), matrix_to_rotvec(RB[:, :3, :3])
    turned = np.linalg.norm(alpha, axis=1) > MIN_RELATIVE_TURN
    H = beta[turned].T @ alpha[turned]
    s = np.linalg.svd(H, compute_uv=False)
    if turned.sum() < 2 or s[1] < MIN_RELATIVE_TURN * max(s[0], 1e-300):
        raise IdentificationError("the poses turn the flange about one axis only: the camera's (or board's) "
                                  "rotation on the flange cannot be found; measure poses that turn the wrist "
                                  "about different axes")
    Rx = kabsch_rotation(H)  # alpha = Rx beta
    M = (RA[:, :3, :3] - np.eye(3)).reshape(-1, 3)
    rhs = (np.einsum("ij,nj->ni", Rx, RB[:, :3, 3]) - RA[:, :3, 3]).reshape(-1)
    tx = np.linalg.lstsq(M, rhs, rcond=None)[0]
    R = make_transform(Rx, tx)
    L = chordal_mean(C @ invert_transform(R)[None] @ invert_transform(A))
    return L, R
