"""Closed-form inverse kinematics of UR-form arms (three parallel axes J2-J4, offset wrist).

All 8 solutions of N poses in one vectorised pass, on the robot's own MDH chain (the form of
:mod:`robocal.kinematics.ur`), each verified by ``robot.fk``. With the flange pose F in the frame
before joint 1 (base, then ``Rx(alpha1) Tx(a1) Ry(beta1)`` removed), and psi, g2..g4, chi, omega
the link angles theta_i + q_i:

* shoulder: the point P = flange - d6 z6 (where axes 5 and 6 meet) lies in the arm plane, at
  ``c2`` along the parallel axes n = Rz(psi) Rx(alpha2) e_z: with (r, phi) the polar
  coordinates of P about axis 1 and k = -sin(alpha2) c2, r sin(phi - psi) = k, so
  psi = phi - asin(k / r) (shoulder 0: P in front of axis 1, P . x1 >= 0) or
  phi - pi + asin(k / r) (shoulder 1);
* wrist: with n6 = F^T z4 (z4 = sg3 sg4 n), cos chi = -s5 s6 n6z and |sin chi| = |(n6x, n6y)|; flip 0 takes
  sin chi >= 0, flip 1 the negative root; omega = atan2(-s5 n6y, s5 n6x) (+ pi for flip 1);
* arm: the origin of frame {4} is P - a5 x4 - d5 z5 (x4, z5 from F, chi and omega exactly); in
  the plane of the parallel axes a planar 2R problem with links a3, a4 gives the elbow angle
  e = sg3 g3 = +-acos(D) (elbow 0: +), g2, and g4 from the direction of x4.

Singular poses get a documented exact answer instead of noise:

* wrist singularity (axes 4 and 6 parallel, |sin chi| < 1e-12): omega = 0 (pi in the flipped
  slot); g4 then takes the whole rotation about the parallel axes, computed from the rotation
  that remains, so the solution is exact for that member of the continuum;
* shoulder singularity (P on the cylinder r = |k| about axis 1; or P on axis 1 when c2 = 0):
  both shoulder solutions coincide (asin argument clamped to +-1); with r = k = 0, psi = phi;
* elbow singularity (arm stretched or folded): the acos argument is clamped, both elbow
  solutions coincide; with the frame-{4} origin on axis 2 (a3 = a4, folded), g2 = 0.

Arguments within 1e-9 (relative) outside their domain are clamped; further out the branch does
not exist (NaN). Every solution is checked with ``robot.fk`` to ``tol`` (1e-9 m / rad); joints are
in the robot's convention, wrapped to [-pi, pi). Slot order as the OPW solver:
``s = 4 * flip + 2 * shoulder + elbow``.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

from robocal.core.errors import ModelError
from robocal.ik.opw_ik import _CHUNK, _CLAMP, _SINGULAR, TOL, _clamp, _wrap, keep_verified
from robocal.kinematics.fk import chain_frames
from robocal.kinematics.kernels import compiled
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform
from robocal.kinematics.ur import URForm

_COMPILED_CHUNK = 16384  # poses per call of the compiled kernel
_NEAR = 1e-6  # |sin chi| below which omega is moved where the arm reaches (see _reachable_omega)


def ur_form(robot: Robot) -> URForm:
    """The robot's UR form; ModelError if its chain has none (:attr:`Robot.has_ur_form`)."""
    if robot.ur_form is None:
        raise ModelError(f"robot {robot.name!r} has no UR form (three parallel axes J2-J4 and an offset "
                         "wrist), so closed-form UR inverse kinematics does not apply")
    return robot.ur_form


def _frames(robot: Robot, form: URForm) -> tuple[np.ndarray, np.ndarray]:
    """``(pre, post)`` 4x4 with F (flange in the frame before joint 1) = pre @ T @ post."""
    return invert_transform(robot.base @ form.pre), invert_transform(robot.tool)


def link_angles(form: URForm, F: np.ndarray, seed_margin: float | None = None) -> np.ndarray:
    """Link angles theta_i + q_i ``(N, 8, 6)`` (rad, slot order) of flange poses F ``(N, 4, 4)``.

    ``seed_margin`` (for seeds, not solutions): out-of-domain arguments are clamped instead of
    giving NaN and the elbow's cosine is kept ``seed_margin`` inside +-1."""
    f = form
    N = F.shape[0]
    R, p = F[:, :3, :3], F[:, :3, 3]
    z6 = R[:, :, 2]
    P = p - f.d6 * z6
    r = np.hypot(P[:, 0], P[:, 1])
    phi = np.arctan2(P[:, 1], P[:, 0])
    k = -f.s2 * f.c2
    ratio = np.where(r > 0, k / np.where(r > 0, r, 1.0), np.where(abs(k) > 0, np.inf, 0.0))
    ratio = np.clip(ratio, -1.0, 1.0) if seed_margin is not None else _clamp(ratio, -1.0, 1.0, _CLAMP)
    lean = np.arcsin(ratio)
    psi = np.stack([phi - lean, phi - np.pi + lean], axis=1)  # (N, 2 shoulder)
    cp, sp = np.cos(psi), np.sin(psi)
    n = np.stack([f.s2 * sp, -f.s2 * cp, np.zeros_like(cp)], axis=-1)  # Rz(psi) Rx(alpha2) e_z
    n6 = (f.sg3 * f.sg4) * np.einsum("nji,nsj->nsi", R, n)  # z4 = +-n, in flange axes (N, 2, 3)
    h = np.hypot(n6[..., 0], n6[..., 1])
    cchi = -f.s5 * f.s6 * n6[..., 2]
    chi0 = np.arctan2(h, cchi)
    singular = h < _SINGULAR
    om0 = np.where(singular, 0.0, np.arctan2(-f.s5 * n6[..., 1], f.s5 * n6[..., 0]))
    chi = np.stack([chi0, -chi0], axis=1)  # (N, 2 flip, 2 shoulder)
    om = np.stack([om0, om0 + np.pi], axis=1)
    # frame 2-: Rz(psi) Tz(d1) Rx(alpha2) Tx(a2); its x = (cp, sp, 0), y = Rz(psi) Rx(alpha2) e_y
    ex = np.stack([cp, sp, np.zeros_like(cp)], axis=-1)[:, None]  # (N, 1, 2, 3)
    ey = np.stack([np.zeros_like(cp), np.zeros_like(cp), np.full_like(cp, f.s2)], axis=-1)[:, None]
    origin = np.stack([f.a2 * cp, f.a2 * sp, np.full_like(cp, f.d1)], axis=-1)[:, None]
    near = h < _NEAR
    if near.any():
        om = np.where(near[:, None], _reachable_omega(f, R, P, chi, om, ex, ey, origin, singular), om)
    cx, sx, co, so = np.cos(chi), np.sin(chi), np.cos(om), np.sin(om)
    # x4 and z5 in flange axes (R6^T x4 = (co cx, -so cx, s6 sx), R6^T z5 = s6 (so, co, 0)), then base
    x4l = np.stack([co * cx, -so * cx, f.s6 * sx], axis=-1)
    z5l = f.s6 * np.stack([so, co, np.zeros_like(co)], axis=-1)
    x4 = np.einsum("nij,nfsj->nfsi", R, x4l)
    z5 = np.einsum("nij,nfsj->nfsi", R, z5l)
    o4 = P[:, None, None] - f.a5 * x4 - f.d5 * z5
    rel = o4 - origin
    Qx, Qy = np.sum(rel * ex, axis=-1), np.sum(rel * ey, axis=-1)
    Phi = np.arctan2(np.sum(x4 * ey, axis=-1), np.sum(x4 * ex, axis=-1))
    D = (Qx * Qx + Qy * Qy - f.a3 * f.a3 - f.a4 * f.a4) / (2.0 * f.a3 * f.a4)
    if seed_margin is None:
        e0 = np.arccos(_clamp(D, -1.0, 1.0, _CLAMP))
    else:
        e0 = np.arccos(np.clip(D, -1.0 + seed_margin, 1.0 - seed_margin))
    e = np.stack([e0, -e0], axis=-1)  # (N, flip, shoulder, elbow)
    Qx, Qy, Phi = Qx[..., None], Qy[..., None], Phi[..., None]
    g2 = np.arctan2(Qy, Qx) - np.arctan2(f.a4 * np.sin(e), f.a3 + f.a4 * np.cos(e))
    g3 = f.sg3 * e
    g4 = f.sg3 * f.sg4 * (Phi - g2 - e)
    shape = e.shape
    angles = (np.broadcast_to(psi[:, None, :, None], shape), g2, g3, g4,
              np.broadcast_to(chi[..., None], shape), np.broadcast_to(om[..., None], shape))
    return np.stack(angles, axis=-1).reshape(N, 8, 6)


def _reachable_omega(f: URForm, R, P, chi, om, ex, ey, origin, singular) -> np.ndarray:
    """omega ``(N, 2 flip, 2 shoulder)`` near a singular wrist (|sin chi| < ``_NEAR``; axes 4 and 6
    (almost) parallel to the arm's axes). There the wrist offset a5 x4 + d5 z5 turns in the arm
    plane with omega, moving the frame-{4} origin on a circle of radius rho = |(a5 cos chi, s6 d5)|
    about P, and omega is barely determined by the orientation (exactly singular: not at all).
    Exactly singular: the point whose distance from axis 2 is nearest sqrt(a3^2 + a4^2) (the elbow
    farthest from its singularity; one side of the circle's centre line in flip 0, the other in
    flip 1). Almost singular: ``om`` moved to the nearest point the arm reaches (the rounding of
    an ill-determined omega must not push a stretched or folded arm out of reach), which changes
    the orientation by |sin chi| times the move: the FK check judges it."""
    w = np.stack([f.a5 * np.cos(chi), np.full_like(chi, f.s6 * f.d5)], axis=-1)  # in flange x, y
    rho = np.hypot(w[..., 0], w[..., 1])
    # M[i, k] = e_i . (flange axis k): the flange x, y axes in frame 2-'s in-plane coordinates
    M = np.einsum("nsij,njk->nsik", np.stack([ex[:, 0], ey[:, 0]], axis=-2), R[:, :, :2])
    rel = P[:, None, None] - origin
    q0 = np.stack([np.sum(rel * ex, axis=-1), np.sum(rel * ey, axis=-1)], axis=-1)  # (N, 1, 2, 2)
    r0 = np.hypot(q0[..., 0], q0[..., 1])
    theta0 = np.arctan2(q0[..., 1], q0[..., 0])
    denom = np.where(rho * r0 > 0, 2.0 * rho * r0, np.inf)
    near, far = (abs(f.a3) - abs(f.a4)) ** 2, (abs(f.a3) + abs(f.a4)) ** 2
    # |Q|^2 = r0^2 + rho^2 - 2 rho r0 cos(beta - theta0): the cosines the arm reaches, and the middle
    lo, hi = (r0 * r0 + rho * rho - far) / denom, (r0 * r0 + rho * rho - near) / denom
    middle = (r0 * r0 + rho * rho - f.a3 * f.a3 - f.a4 * f.a4) / denom
    # the current direction of the offset in the plane: u = M Rot(-om) w / rho
    c, s = np.cos(om), np.sin(om)
    v = np.stack([c * w[..., 0] + s * w[..., 1], -s * w[..., 0] + c * w[..., 1]], axis=-1)
    u = np.einsum("nsik,nfsk->nfsi", M, v)
    delta = np.arctan2(u[..., 1], u[..., 0]) - theta0
    flip_side = np.array([1.0, -1.0])[None, :, None]
    side = np.where(singular[:, None], flip_side, np.where(np.sin(delta) < 0, -1.0, 1.0))
    cosine = np.where(singular[:, None], middle, np.clip(np.cos(delta), lo, hi))
    beta = theta0 + side * np.arccos(np.clip(cosine, -1.0, 1.0))
    u = np.stack([np.cos(beta), np.sin(beta)], axis=-1)
    v = np.einsum("nsik,nfsi->nfsk", M, u)  # M^T u: the offset's direction in flange x, y
    moved = np.arctan2(w[..., 1], w[..., 0]) - np.arctan2(v[..., 1], v[..., 0])
    return np.where(np.isfinite(denom), moved, om)


def _joints(form: URForm, angles: np.ndarray) -> np.ndarray:
    """Robot joints (rad, wrapped to [-pi, pi)) of link angles: q = angle - theta."""
    return _wrap(angles - form.theta)


def _solve_chunk(robot: Robot, form: URForm, pre: np.ndarray, post: np.ndarray, T: np.ndarray,
                 tol: float) -> np.ndarray:
    """Verified solutions of world poses ``T``; F = pre @ T @ post."""
    return keep_verified(robot, _joints(form, link_angles(form, pre @ T @ post)), T, tol)


def chunk_solver(robot: Robot, tol: float = TOL) -> tuple[Callable[[np.ndarray], np.ndarray], int]:
    """The chunk solver of the kernels in use (numpy or the compiled twin) and its chunk size."""
    form = ur_form(robot)
    pre, post = _frames(robot, form)
    kernel = compiled("robocal.ik.ur_numba")
    if kernel is None:
        return partial(_solve_chunk, robot, form, pre, post, tol=tol), _CHUNK
    return kernel.chunk_solver(robot, form, pre, post, tol), _COMPILED_CHUNK


def seed_branches(robot: Robot, T: np.ndarray, seed_margin: float) -> np.ndarray:
    """Unverified seeds ``(N, 8, 6)`` in every slot, out-of-reach arguments clamped (see
    :func:`robocal.ik.opw_ik.seed_branches`)."""
    form = ur_form(robot)
    pre, post = _frames(robot, form)
    return _joints(form, link_angles(form, pre @ T @ post, seed_margin))


def branch_bits(robot: Robot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(shoulder, elbow, flip)`` bool arrays of joints ``(..., 6)`` on the UR-form ``robot`` (a
    calibrated robot's branches are those of its nominal model): P behind axis 1 (P . x1 < 0),
    the elbow angle sg3 (theta3 + q3) negative, sin(theta5 + q5) < 0 (the slots above)."""
    form = ur_form(robot)
    q = np.asarray(q, float)
    flat = q.reshape(-1, 6)
    frames = chain_frames(robot.links, np.eye(4), np.eye(4), flat, frames=True)[1]
    o1, x1 = frames[:, 1, :3, 3], frames[:, 1, :3, 0]
    ahead = np.sum((frames[:, 5, :3, 3] - o1) * x1, axis=1).reshape(q.shape[:-1])
    elbow = _wrap(form.sg3 * (q[..., 2] + form.theta[2]))
    return ahead < 0, elbow < 0, np.sin(q[..., 4] + form.theta[4]) < 0
