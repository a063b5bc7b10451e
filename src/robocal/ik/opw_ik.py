"""Closed-form inverse kinematics of ortho-parallel arms with a spherical wrist (OPW form).

All 8 branches of N poses in one vectorised pass, each verified by the robot's own MDH forward
kinematics (``robot.fk``); there is no second OPW forward model here.

Branch slot order (the order of py-opw-kinematics' ``ReachResult`` and of opw_kinematics):
``s = 4 * wrist_flip + 2 * shoulder + elbow`` with, on the paper angles (Brandstoetter et al.
2014, theta = q * sign - offset):

* shoulder 0: theta1 = atan2(cy, cx) - atan2(b, r), the wrist centre in front of the J1 axis;
  shoulder 1: theta1 = atan2(cy, cx) + atan2(b, r) - pi, the arm reaching back over J1;
* elbow 0: theta3 = +acos(D) - psi3; elbow 1: theta3 = -acos(D) - psi3 (psi3 = atan2(a2, c3));
* wrist_flip 0: sin(theta5) >= 0; wrist_flip 1: (theta4 + pi, -theta5, theta6 - pi).

Singular poses get a documented exact answer instead of noise:

* wrist singularity (|sin theta5| < 1e-12, theta5 = 0 or +-pi): theta4 = 0 (paper angle, pi
  in the flipped slot) and theta6 takes the whole rotation about the aligned axes; theta5 and
  theta6 are always computed *after* theta4 from the rotation that remains, so they are exact
  for any theta4 (the reference C++ solver gets theta5 = +-pi wrong; this one does not);
* shoulder singularity (wrist centre on the J1 axis, b = 0): theta1 = 0 for shoulder 0 and pi
  for shoulder 1 (any theta1 reaches the pose);
* edge of reach: acos/sqrt arguments within 1e-9 (relative) of their domain are clamped, so a
  fully stretched or folded arm keeps both (coinciding) elbow branches and no phantom branch
  appears; the forward-kinematics check below is the final judge.

Every solution is checked with ``robot.fk``; one whose TCP is more than ``tol`` (1e-9 m /
1e-9 rad) off the target becomes NaN. Output joints are in the robot's convention, wrapped to
[-pi, pi).

With the optional numba extra, :mod:`robocal.ik.opw_numba` runs the same formulas and the same
check compiled, pose by pose (see :mod:`robocal.kinematics.kernels` for the choice).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

from robocal.core.errors import DataError, ModelError
from robocal.kinematics.fk import chain_fk, chain_frames
from robocal.kinematics.kernels import compiled
from robocal.kinematics.model import Robot
from robocal.kinematics.opw import GEOMETRY, OPWParameters
from robocal.kinematics.transforms import invert_transform, is_rigid

_CHUNK = 1024  # poses per chunk (8 branches each): keeps the numpy temporaries in cache
_COMPILED_CHUNK = 16384  # poses per call of the compiled kernel (it blocks internally)
_SINGULAR = 1e-12  # |sin theta5| below which the wrist is treated as singular
_CLAMP = 1e-9  # relative tolerance for clamping acos / sqrt arguments at the edge of reach
TOL = 1e-9  # m and rad: largest forward-kinematics error of a returned solution
SEED_MARGIN = 1e-3  # seeds keep the elbow's cosine this far inside +-1 (the arm ~2.6 deg off straight)


def opw_model(robot: Robot) -> Robot:
    """The OPW-form model of the robot's arm (:attr:`Robot.opw_model`: its own, or the one its
    chain's geometry has); ModelError naming why there is none."""
    model = robot.opw_model
    if model is not None:
        return model
    if robot.opw is None:
        raise ModelError(
            f"robot {robot.name!r} has no OPW form (its joint lines are not those of an ortho-parallel "
            "arm with a spherical wrist), so closed-form inverse kinematics is not available; use the "
            "numeric solver rc.ik.solve(robot, poses, seeds) instead")
    raise ModelError(
        f"robot {robot.name!r}: its chain no longer follows its nominal OPW form (a calibrated model "
        "or one with joint-error terms), so closed-form inverse kinematics does not apply; use the "
        "numeric solver rc.ik.solve(robot, poses), which is seeded by the nominal closed form")


def opw_form(robot: Robot) -> OPWParameters:
    """The OPW set of the robot's arm (:func:`opw_model`); ModelError without one."""
    return opw_model(robot).opw


def check_poses(poses) -> np.ndarray:
    """Poses as a ``(N, 4, 4)`` float array of proper rigid transforms, else DataError."""
    T = np.asarray(poses, dtype=float)
    if T.ndim == 2:
        T = T[None]
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise DataError(f"poses must be 4x4 transforms of shape (N, 4, 4), got {T.shape}")
    bad = np.flatnonzero(~is_rigid(T))
    if bad.size:
        raise DataError(f"pose(s) {bad[:10].tolist()}{' ...' if bad.size > 10 else ''} are not rigid "
                        "transforms (rotation not orthonormal with det +1, last row not 0 0 0 1, "
                        "or NaN); check the orientation columns and units")
    return T


def _flange_correction(robot: Robot, opw: OPWParameters) -> np.ndarray:
    """Q with chain(q) = OPW_flange(q) * Q, from the paper's zero pose (identity rotation,
    flange at (a1 + a2, b, c1 + c2 + c3 + c4)); absorbs how the MDH conversion split the flange
    orientation between frame {6} and the tool. Frame {0} is the OPW base frame."""
    q0 = np.asarray(opw.offsets, float) * np.asarray(opw.signs, float)
    F6 = chain_frames(robot.links, np.eye(4), np.eye(4), q0[None])[0]
    G0 = np.eye(4)
    G0[:3, 3] = (opw.a1 + opw.a2, opw.b, opw.c1 + opw.c2 + opw.c3 + opw.c4)
    return invert_transform(G0) @ F6


def _clamp(x: np.ndarray, lo: float, hi: float, tol: float) -> np.ndarray:
    """Clip x into [lo, hi] when within tol outside, NaN further out."""
    out = np.clip(x, lo, hi)
    return np.where((x < lo - tol) | (x > hi + tol), np.nan, out)


def _geometry(opw: OPWParameters) -> np.ndarray:
    """a1 a2 b c1 c2 c3 c4 (m), then k = |J3 -> wrist centre| (m), its angle psi3 (rad) and the
    squared length (m^2) that scales the edge-of-reach clamp of the sqrt argument."""
    a1, a2, b, c1, c2, c3, c4 = (float(getattr(opw, k)) for k in GEOMETRY)
    k = float(np.hypot(a2, c3))
    scale = max(a1 * a1 + b * b + c2 * c2 + k * k, 1e-12)
    return np.array([a1, a2, b, c1, c2, c3, c4, k, np.arctan2(a2, c3), scale])


def paper_branches(opw: OPWParameters, flange: np.ndarray, seed_margin: float | None = None) -> np.ndarray:
    """Paper angles ``(N, 8, 6)`` (rad) of flange poses ``(N, 4, 4)`` in the OPW base frame.

    ``seed_margin`` (for seeds, not solutions): every out-of-reach argument is clamped instead of
    giving NaN, and the elbow's cosine is kept ``seed_margin`` inside +-1, so a pose a little
    beyond the nominal reach still gets its branches, off the stretched or folded arm."""
    a1, a2, b, c1, c2, c3, c4, k, psi3, scale = _geometry(opw)
    N = flange.shape[0]
    R = flange[:, :3, :3]
    C = flange[:, :3, 3] - c4 * R[:, :, 2]  # wrist centre
    rho2 = C[:, 0] ** 2 + C[:, 1] ** 2
    r = np.sqrt(_clamp(rho2 - b * b, 0.0, np.inf, _CLAMP * scale if seed_margin is None else np.inf))
    phi_c = np.arctan2(C[:, 1], C[:, 0])
    beta_b = np.arctan2(b, r)
    q1 = np.stack([phi_c - beta_b, phi_c + beta_b - np.pi], axis=1)  # (N, 2) shoulder
    xs = np.stack([r - a1, -r - a1], axis=1)  # horizontal distance J2 -> C in the arm plane
    zs = (C[:, 2] - c1)[:, None]
    s2 = xs * xs + zs * zs
    D = (s2 - c2 * c2 - k * k) / (2.0 * c2 * k) if c2 * k > 0 else np.full_like(s2, np.nan)
    if seed_margin is None:
        phi = np.arccos(_clamp(D, -1.0, 1.0, _CLAMP))  # (N, 2)
    else:
        phi = np.arccos(np.clip(D, -1.0 + seed_margin, 1.0 - seed_margin))
    bend = np.arctan2(k * np.sin(phi), c2 + k * np.cos(phi))  # atan2 is odd in y: -bend for -phi
    q2 = np.arctan2(xs, zs)[:, :, None] - np.stack([bend, -bend], axis=2)  # (N, 2 shoulder, 2 elbow)
    q3 = np.stack([phi, -phi], axis=2) - psi3
    q1 = np.broadcast_to(q1[:, :, None], q2.shape)
    # wrist: M = (Rz(q1) Ry(q2 + q3))^T R = Rz(q4) Ry(q5) Rz(q6)
    c1_, s1_ = np.cos(q1), np.sin(q1)
    t23 = q2 + q3
    c23, s23 = np.cos(t23), np.sin(t23)
    Rb = R[:, None, None]  # (N, 1, 1, 3, 3)
    u0 = (c1_ * c23, s1_ * c23, -s23)
    u1 = (-s1_, c1_, np.zeros_like(c1_))
    u2 = (c1_ * s23, s1_ * s23, c23)

    def m(u, j):
        return u[0] * Rb[..., 0, j] + u[1] * Rb[..., 1, j] + u[2] * Rb[..., 2, j]

    M02, M12, M22 = m(u0, 2), m(u1, 2), m(u2, 2)
    M00, M10, M01, M11 = m(u0, 0), m(u1, 0), m(u0, 1), m(u1, 1)
    singular = M02 * M02 + M12 * M12 < _SINGULAR * _SINGULAR
    q4 = np.where(singular, 0.0, np.arctan2(M12, M02))
    c4_, s4_ = np.cos(q4), np.sin(q4)
    # remaining rotation Rz(-q4) M = Ry(q5) Rz(q6): exact for whatever q4 was chosen
    p02 = c4_ * M02 + s4_ * M12
    p10 = c4_ * M10 - s4_ * M00
    p11 = c4_ * M11 - s4_ * M01
    q5 = np.arctan2(p02, M22)
    q6 = np.arctan2(p10, p11)
    q5f = -q5  # = arctan2(-p02, M22)
    q6f = np.arctan2(-p10, -p11)
    out = np.empty((N, 2, 2, 2, 6))  # (flip, shoulder, elbow)
    for f, (w4, w5, w6) in enumerate(((q4, q5, q6), (q4 + np.pi, q5f, q6f))):
        for j, v in enumerate((q1, q2, q3, w4, w5, w6)):
            out[:, f, :, :, j] = v
    return out.reshape(N, 8, 6)


def _wrap(q: np.ndarray) -> np.ndarray:
    """Angles into [-pi, pi) (floor is several times faster than np.remainder)."""
    return q - (2 * np.pi) * np.floor((q + np.pi) * (0.5 / np.pi))


def _robot_joints(opw: OPWParameters, paper: np.ndarray) -> np.ndarray:
    """Robot joints (rad, wrapped to [-pi, pi)) of paper angles ``(..., 6)``: q = (theta + offset) * sign."""
    return _wrap((paper + np.asarray(opw.offsets, float)) * np.asarray(opw.signs, float))


def _opw_frames(robot: Robot, opw: OPWParameters) -> tuple[np.ndarray, np.ndarray]:
    """``(pre, post)`` 4x4 with flange (OPW base frame) = pre @ T @ post for world TCP poses T."""
    pre = invert_transform(robot.base)
    post = invert_transform(robot.tool) @ invert_transform(_flange_correction(robot, opw))
    return pre, post


def keep_verified(robot: Robot, q: np.ndarray, T: np.ndarray, tol: float) -> np.ndarray:
    """Solutions ``q`` ``(N, B, 6)`` of world poses ``T`` ``(N, 4, 4)``, in place: rows with NaN or
    whose ``robot.fk`` is more than ``tol`` (m, rad) off their pose become NaN."""
    B = q.shape[1]
    ok = np.isfinite(q).all(axis=2)
    q[~ok] = 0.0
    fk = chain_fk(robot.links, robot.base, robot.tool, q.reshape(-1, 6)).reshape(-1, B, 16)
    # position error, and ||R_fk - R_target||_F / sqrt(2) = 2 sin(angle / 2) ~ the rotation angle
    diff = fk - T.reshape(-1, 1, 16)
    sq = diff * diff
    dp2 = sq[..., 3] + sq[..., 7] + sq[..., 11]
    dr2 = (sq[..., 0:3].sum(axis=2) + sq[..., 4:7].sum(axis=2) + sq[..., 8:11].sum(axis=2)) / 2.0
    ok &= (dp2 <= tol * tol) & (dr2 <= tol * tol)
    q[~ok] = np.nan
    return q


def _solve_chunk(robot: Robot, opw: OPWParameters, pre: np.ndarray, post: np.ndarray, T: np.ndarray,
                 tol: float) -> np.ndarray:
    """Verified branches of world poses ``T``; flange = pre @ T @ post in the OPW base frame."""
    return keep_verified(robot, _robot_joints(opw, paper_branches(opw, pre @ T @ post)), T, tol)


def chunk_solver(robot: Robot, tol: float = TOL) -> tuple[Callable[[np.ndarray], np.ndarray], int]:
    """The chunk solver of the kernels in use (numpy or the compiled twin) and its chunk size:
    world poses ``(M, 4, 4)`` -> verified branches ``(M, 8, 6)``. ModelError without an OPW form."""
    model = opw_model(robot)  # the same arm, its chain in the OPW form; solutions verified on robot's own
    opw = model.opw
    pre, post = _opw_frames(model, opw)
    kernel = compiled("robocal.ik.opw_numba")
    if kernel is None:
        return partial(_solve_chunk, robot, opw, pre, post, tol=tol), _CHUNK
    return kernel.chunk_solver(robot, _geometry(opw), np.asarray(opw.offsets, float),
                               np.asarray(opw.signs, float), pre, post, tol), _COMPILED_CHUNK


def seed_branches(robot: Robot, T: np.ndarray) -> np.ndarray:
    """Seeds ``(N, 8, 6)`` for numeric IK in every branch slot: the closed form of the robot's OPW
    form with out-of-reach arguments clamped (:func:`paper_branches` with ``SEED_MARGIN``), not
    verified: a pose just beyond the nominal reach (a calibrated robot may reach it) still gets a
    seed in each branch, off the singular stretched arm where the reach's gradient vanishes."""
    model = opw_model(robot)
    opw = model.opw
    pre, post = _opw_frames(model, opw)
    return _robot_joints(opw, paper_branches(opw, pre @ T @ post, seed_margin=SEED_MARGIN))


def branch_bits(opw: OPWParameters, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(shoulder, elbow, flip)`` bool arrays of joints ``(..., 6)`` (rad) by the OPW form ``opw``
    (a calibrated robot's branches are those of its nominal form): the wrist centre behind the
    J1 axis, the elbow angle negative, sin(theta5) < 0 (the slot of the module docstring)."""
    theta = np.asarray(q, float) * np.asarray(opw.signs, float) - np.asarray(opw.offsets, float)
    psi3, k = np.arctan2(opw.a2, opw.c3), np.hypot(opw.a2, opw.c3)
    t2, t3 = theta[..., 1], theta[..., 2]
    elbow_angle = np.remainder(t3 + psi3 + np.pi, 2 * np.pi) - np.pi
    reach_x = opw.a1 + opw.c2 * np.sin(t2) + k * np.sin(t2 + t3 + psi3)  # wrist centre x, J1 frame
    return reach_x < 0, elbow_angle < 0, np.sin(theta[..., 4]) < 0


def branch_slot(opw: OPWParameters, q: np.ndarray) -> np.ndarray:
    """Closed-form branch slot ``(...,)`` of joints ``(..., 6)``: 4 * flip + 2 * shoulder + elbow."""
    shoulder, elbow, flip = branch_bits(opw, q)
    return 4 * flip.astype(int) + 2 * shoulder.astype(int) + elbow.astype(int)
