"""Compiled (numba) twin of the closed-form UR solver of :mod:`robocal.ik.ur_ik`.

Imported only through :func:`robocal.kinematics.kernels.compiled`. Pose by pose it evaluates the
formulas of :func:`robocal.ik.ur_ik.link_angles` in the same order (same clamps, same singular
rules, same slot order), turns them into wrapped robot joints, then verifies all 8 solutions of a
block of poses with the robot's MDH chain (:func:`robocal.kinematics.fk_numba.chain_block`)
against the target to ``tol`` (m, rad): nothing is returned unchecked. numba's on-disk cache is
keyed on this file only: after editing what it compiles in (``opw_numba._clamp``,
``opw_numba._affine``, ``opw_numba._wrap_one``, ``fk_numba.chain_block``), delete the cache files.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba
import numpy as np

from robocal.ik.opw_ik import _CLAMP, _SINGULAR
from robocal.ik.opw_numba import _affine, _clamp, _wrap_one, write_checked
from robocal.ik.ur_ik import _NEAR
from robocal.kinematics.fk_numba import chain_block, link_constants
from robocal.kinematics.model import Robot
from robocal.kinematics.ur import URForm

_POSES = 64  # poses per verification block (8 solutions each)
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@numba.njit(**_JIT)
def _reachable_omega(F, g, Px, Py, Pz, cp, sp, chi, om, flip_side, singular):
    """omega near a singular wrist: ``ur_ik._reachable_omega`` for one pose, shoulder and flip."""
    d1, s2, a2, a3, a4, a5, d5, s6 = g[0], g[1], g[2], g[5], g[6], g[9], g[10], g[11]
    w0, w1 = a5 * math.cos(chi), s6 * d5
    rho = math.hypot(w0, w1)
    M00, M01 = cp * F[0, 0] + sp * F[1, 0], cp * F[0, 1] + sp * F[1, 1]
    M10, M11 = s2 * F[2, 0], s2 * F[2, 1]
    q0x, q0y = (Px - a2 * cp) * cp + (Py - a2 * sp) * sp, s2 * (Pz - d1)
    r0 = math.hypot(q0x, q0y)
    if not rho * r0 > 0:
        return om
    denom = 2.0 * rho * r0
    theta0 = math.atan2(q0y, q0x)
    base = r0 * r0 + rho * rho
    if singular:
        side, cosine = flip_side, (base - a3 * a3 - a4 * a4) / denom
    else:
        c, s = math.cos(om), math.sin(om)
        v0, v1 = c * w0 + s * w1, -s * w0 + c * w1
        delta = math.atan2(M10 * v0 + M11 * v1, M00 * v0 + M01 * v1) - theta0
        side = -1.0 if math.sin(delta) < 0 else 1.0
        lo = (base - (abs(a3) + abs(a4)) ** 2) / denom
        hi = (base - (abs(a3) - abs(a4)) ** 2) / denom
        cosine = min(max(math.cos(delta), lo), hi)
    beta = theta0 + side * math.acos(min(max(cosine, -1.0), 1.0))
    u0, u1 = math.cos(beta), math.sin(beta)
    return math.atan2(w1, w0) - math.atan2(M01 * u0 + M11 * u1, M00 * u0 + M10 * u1)


@numba.njit(**_JIT)
def _ur_pose(F, g, out, lane):
    """Link angles of flange ``F`` (4x4, frame before joint 1) into ``out[:, lane:lane + 8]``;
    g: d1 s2 a2 sg3 sg4 a3 a4 c2 s5 a5 d5 s6 d6 (:meth:`URForm.geometry`)."""
    d1, s2, a2, sg3, sg4, a3, a4, c2 = g[0], g[1], g[2], g[3], g[4], g[5], g[6], g[7]
    s5, a5, d5, s6, d6 = g[8], g[9], g[10], g[11], g[12]
    Px, Py, Pz = F[0, 3] - d6 * F[0, 2], F[1, 3] - d6 * F[1, 2], F[2, 3] - d6 * F[2, 2]
    r = math.hypot(Px, Py)
    phi = math.atan2(Py, Px)
    k = -s2 * c2
    ratio = k / r if r > 0 else (np.inf if abs(k) > 0 else 0.0)
    lean = math.asin(_clamp(ratio, -1.0, 1.0, _CLAMP))
    sigma = sg3 * sg4
    for sh in range(2):
        psi = phi - lean if sh == 0 else phi - np.pi + lean
        cp, sp = math.cos(psi), math.sin(psi)
        n0, n1 = s2 * sp, -s2 * cp  # n = Rz(psi) Rx(alpha2) e_z; z4 = sigma n
        m0 = sigma * (F[0, 0] * n0 + F[1, 0] * n1)
        m1 = sigma * (F[0, 1] * n0 + F[1, 1] * n1)
        m2 = sigma * (F[0, 2] * n0 + F[1, 2] * n1)
        h = math.hypot(m0, m1)
        chi0 = math.atan2(h, -s5 * s6 * m2)
        om0 = 0.0 if h < _SINGULAR else math.atan2(-s5 * m1, s5 * m0)
        for fl in range(2):
            chi = chi0 if fl == 0 else -chi0
            om = om0 if fl == 0 else om0 + np.pi
            if h < _NEAR:
                om = _reachable_omega(F, g, Px, Py, Pz, cp, sp, chi, om, 1.0 if fl == 0 else -1.0,
                                      h < _SINGULAR)
            cx, sx, co, so = math.cos(chi), math.sin(chi), math.cos(om), math.sin(om)
            l0, l1, l2 = co * cx, -so * cx, s6 * sx  # x4 in flange axes
            z0, z1 = s6 * so, s6 * co  # z5 in flange axes (z component 0)
            x4 = (F[0, 0] * l0 + F[0, 1] * l1 + F[0, 2] * l2, F[1, 0] * l0 + F[1, 1] * l1 + F[1, 2] * l2,
                  F[2, 0] * l0 + F[2, 1] * l1 + F[2, 2] * l2)
            z5 = (F[0, 0] * z0 + F[0, 1] * z1, F[1, 0] * z0 + F[1, 1] * z1, F[2, 0] * z0 + F[2, 1] * z1)
            o0 = Px - a5 * x4[0] - d5 * z5[0] - a2 * cp
            o1 = Py - a5 * x4[1] - d5 * z5[1] - a2 * sp
            o2 = Pz - a5 * x4[2] - d5 * z5[2] - d1
            Qx, Qy = o0 * cp + o1 * sp, s2 * o2  # frame 2-: x = (cp, sp, 0), y = (0, 0, s2)
            Phi = math.atan2(s2 * x4[2], x4[0] * cp + x4[1] * sp)
            D = (Qx * Qx + Qy * Qy - a3 * a3 - a4 * a4) / (2.0 * a3 * a4)
            e0 = math.acos(_clamp(D, -1.0, 1.0, _CLAMP))
            reach = math.atan2(Qy, Qx)
            for el in range(2):
                e = e0 if el == 0 else -e0
                g2 = reach - math.atan2(a4 * math.sin(e), a3 + a4 * math.cos(e))
                slot = lane + 4 * fl + 2 * sh + el
                out[0, slot], out[1, slot], out[2, slot] = psi, g2, sg3 * e
                out[3, slot], out[4, slot], out[5, slot] = sigma * (Phi - g2 - e), chi, om


@numba.njit(**_JIT)
def _solve_kernel(T, pre, post, geom, theta, A, a, d, base, tool, tol, out):
    """``out`` ``(N, 8, 6)`` <- verified solutions (robot joints, wrapped; NaN where absent or
    failing the check against the world pose with base and tool) of world poses ``T``
    ``(N, 4, 4)``; F = pre @ T @ post."""
    N = T.shape[0]
    P = min(_POSES, max(N, 1))
    q = np.empty((6, 8 * P))
    phi, c, s, G = np.empty((6, 8 * P)), np.empty((6, 8 * P)), np.empty((6, 8 * P)), np.empty((12, 8 * P))
    valid = np.empty(8 * P, dtype=np.bool_)
    W, flange = np.empty((4, 4)), np.empty((4, 4))
    tol2 = tol * tol
    for start in range(0, N, P):
        m = min(P, N - start)
        for p in range(m):
            _affine(pre, T[start + p], W)
            _affine(W, post, flange)
            _ur_pose(flange, geom, q, 8 * p)
        for L in range(8 * m):
            ok = True
            for j in range(6):
                q[j, L] = _wrap_one(q[j, L] - theta[j])
                ok &= np.isfinite(q[j, L])
            valid[L] = ok
            for j in range(6):
                phi[j, L] = (q[j, L] if ok else 0.0) + theta[j]
        chain_block(phi, 8 * m, A, a, d, base, c, s, G)
        write_checked(G, q, valid, T, tool, start, m, tol2, out)


def chunk_solver(robot: Robot, form: URForm, pre: np.ndarray, post: np.ndarray,
                 tol: float) -> Callable[[np.ndarray], np.ndarray]:
    """The compiled ``ur_ik._solve_chunk``: world poses ``(N, 4, 4)`` -> verified solutions
    ``(N, 8, 6)``."""
    consts = (np.ascontiguousarray(pre, dtype=float), np.ascontiguousarray(post, dtype=float),
              form.geometry(), *link_constants(robot.links),
              np.ascontiguousarray(robot.base, dtype=float), np.ascontiguousarray(robot.tool, dtype=float),
              float(tol))

    def solve(T: np.ndarray) -> np.ndarray:
        out = np.empty((T.shape[0], 8, 6))
        _solve_kernel(np.ascontiguousarray(T, dtype=float), *consts, out)
        return out

    return solve
