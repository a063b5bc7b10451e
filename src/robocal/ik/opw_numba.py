"""Compiled (numba) twin of the closed-form OPW solver of :mod:`robocal.ik.opw_ik`.

Imported only through :func:`robocal.kinematics.kernels.compiled`. Pose by pose it evaluates the
formulas of :func:`robocal.ik.opw_ik.paper_branches` in the same order (same clamps, same
singular-wrist rule, same slot order), turns them into robot joints as ``_solve_chunk`` does, then
verifies all 8 solutions of a block of poses with the robot's MDH chain
(:func:`robocal.kinematics.fk_numba.chain_block`, the compiled ``robot.fk``) against the target to
``tol`` (m, rad): nothing is returned unchecked. The kernel compiles ``opw_ik._wrap`` and
``fk_numba.chain_block`` into itself, and numba's on-disk cache is keyed on this file only: after
editing those, delete the cache files (see :mod:`robocal.kinematics.fk_numba`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba
import numpy as np

from robocal.ik.opw_ik import _CLAMP, _SINGULAR, _wrap
from robocal.kinematics.fk_numba import chain_block, cos_sin, link_constants
from robocal.kinematics.model import Robot

_POSES = 64  # poses per verification block (8 solutions each)
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}
_wrap_one = numba.njit(_wrap)  # the numpy path's wrap into [-pi, pi), compiled for one value


@numba.njit
def _clamp(x: float, lo: float, hi: float, tol: float) -> float:
    """x clipped into [lo, hi] when within tol outside, NaN further out (NaN stays NaN)."""
    if x < lo:
        return lo if x >= lo - tol else np.nan
    if x > hi:
        return hi if x <= hi + tol else np.nan
    return x


@numba.njit
def _affine(A, B, C):
    """``C`` <- A @ B for 4x4 rigid transforms (last row 0 0 0 1)."""
    for i in range(3):
        for j in range(4):
            C[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j] + A[i, 3] * B[3, j]
    C[3, 0], C[3, 1], C[3, 2], C[3, 3] = 0.0, 0.0, 0.0, 1.0


@numba.njit
def write_checked(F, q, valid, T, tool, start, m, tol2, out):
    """Copy the 8 * ``m`` solutions ``q`` (6, 8m) of poses ``T[start:start + m]`` into ``out``
    (N, 8, 6), NaN where a lane is not ``valid`` or its forward kinematics (link frames ``F``
    (12, 8m) from chain_block, times ``tool``) misses the pose by more than sqrt(``tol2``)
    in position (m) or in rotation (the matrix difference's Frobenius norm / sqrt 2)."""
    for L in range(8 * m):
        target = T[start + L // 8]
        dp2, dr2 = 0.0, 0.0
        for row in range(3):
            x0, x1, x2 = F[4 * row, L], F[4 * row + 1, L], F[4 * row + 2, L]
            for col in range(4):
                e = x0 * tool[0, col] + x1 * tool[1, col] + x2 * tool[2, col]
                if col == 3:
                    e = (e + F[4 * row + 3, L]) - target[row, 3]
                    dp2 += e * e
                else:
                    e = e - target[row, col]
                    dr2 += e * e
        ok = valid[L] and dp2 <= tol2 and dr2 / 2.0 <= tol2
        row_out = out[start + L // 8, L % 8]
        for j in range(6):
            row_out[j] = q[j, L] if ok else np.nan


@numba.njit(**_JIT)
def _paper_pose(F, geom, out, lane):
    """Paper angles of flange ``F`` (4x4, OPW base frame) into ``out[:, lane:lane + 8]``; geom:
    a1 a2 b c1 c2 c3 c4, k, psi3, clamp scale (``opw_ik._geometry``)."""
    a1, b, c1, c2, c4 = geom[0], geom[2], geom[3], geom[4], geom[6]
    k, psi3, scale = geom[7], geom[8], geom[9]
    C0, C1, C2 = F[0, 3] - c4 * F[0, 2], F[1, 3] - c4 * F[1, 2], F[2, 3] - c4 * F[2, 2]
    rho2 = C0 ** 2 + C1 ** 2
    r = math.sqrt(_clamp(rho2 - b * b, 0.0, np.inf, _CLAMP * scale))
    phi_c = math.atan2(C1, C0)
    beta_b = math.atan2(b, r)
    zs = C2 - c1
    for sh in range(2):
        q1 = phi_c - beta_b if sh == 0 else phi_c + beta_b - np.pi
        xs = r - a1 if sh == 0 else -r - a1
        s2 = xs * xs + zs * zs
        D = (s2 - c2 * c2 - k * k) / (2.0 * c2 * k) if c2 * k > 0 else np.nan
        phi = math.acos(_clamp(D, -1.0, 1.0, _CLAMP))
        cp, sp = cos_sin(phi)
        bend = math.atan2(k * sp, c2 + k * cp)
        reach = math.atan2(xs, zs)
        c1_, s1_ = cos_sin(q1)
        for el in range(2):
            q2 = reach - (bend if el == 0 else -bend)
            q3 = (phi if el == 0 else -phi) - psi3
            c23, s23 = cos_sin(q2 + q3)
            # M = (Rz(q1) Ry(q2 + q3))^T R with rows u0, u1, u2 of (Rz(q1) Ry(q2 + q3))^T
            u00, u01, u02 = c1_ * c23, s1_ * c23, -s23
            u10, u11, u12 = -s1_, c1_, 0.0
            u20, u21, u22 = c1_ * s23, s1_ * s23, c23
            M02 = u00 * F[0, 2] + u01 * F[1, 2] + u02 * F[2, 2]
            M12 = u10 * F[0, 2] + u11 * F[1, 2] + u12 * F[2, 2]
            M22 = u20 * F[0, 2] + u21 * F[1, 2] + u22 * F[2, 2]
            M00 = u00 * F[0, 0] + u01 * F[1, 0] + u02 * F[2, 0]
            M10 = u10 * F[0, 0] + u11 * F[1, 0] + u12 * F[2, 0]
            M01 = u00 * F[0, 1] + u01 * F[1, 1] + u02 * F[2, 1]
            M11 = u10 * F[0, 1] + u11 * F[1, 1] + u12 * F[2, 1]
            q4 = 0.0 if M02 * M02 + M12 * M12 < _SINGULAR * _SINGULAR else math.atan2(M12, M02)
            c4_, s4_ = cos_sin(q4)
            p02 = c4_ * M02 + s4_ * M12
            p10 = c4_ * M10 - s4_ * M00
            p11 = c4_ * M11 - s4_ * M01
            q5 = math.atan2(p02, M22)
            slot = lane + 2 * sh + el
            flip = slot + 4
            out[0, slot], out[1, slot], out[2, slot] = q1, q2, q3
            out[0, flip], out[1, flip], out[2, flip] = q1, q2, q3
            out[3, slot], out[4, slot], out[5, slot] = q4, q5, math.atan2(p10, p11)
            out[3, flip], out[4, flip], out[5, flip] = q4 + np.pi, -q5, math.atan2(-p10, -p11)


@numba.njit(**_JIT)
def _solve_kernel(T, pre, post, geom, offsets, signs, theta, A, a, d, base, tool, tol, out):
    """``out`` ``(N, 8, 6)`` <- verified branches (robot joints, wrapped; NaN where absent or
    failing the check) of world poses ``T`` ``(N, 4, 4)``; flange = pre @ T @ post."""
    N = T.shape[0]
    P = min(_POSES, max(N, 1))
    q = np.empty((6, 8 * P))
    phi, c, s, F = np.empty((6, 8 * P)), np.empty((6, 8 * P)), np.empty((6, 8 * P)), np.empty((12, 8 * P))
    valid = np.empty(8 * P, dtype=np.bool_)
    W, flange = np.empty((4, 4)), np.empty((4, 4))
    tol2 = tol * tol
    for start in range(0, N, P):
        m = min(P, N - start)
        for p in range(m):
            _affine(pre, T[start + p], W)
            _affine(W, post, flange)
            _paper_pose(flange, geom, q, 8 * p)
        for L in range(8 * m):
            ok = True
            for j in range(6):
                q[j, L] = _wrap_one((q[j, L] + offsets[j]) * signs[j])
                ok &= np.isfinite(q[j, L])
            valid[L] = ok
            for j in range(6):
                phi[j, L] = (q[j, L] if ok else 0.0) + theta[j]
        chain_block(phi, 8 * m, A, a, d, base, c, s, F)
        write_checked(F, q, valid, T, tool, start, m, tol2, out)


def chunk_solver(robot: Robot, geometry: np.ndarray, offsets: np.ndarray, signs: np.ndarray,
                 pre: np.ndarray, post: np.ndarray, tol: float) -> Callable[[np.ndarray], np.ndarray]:
    """The compiled ``opw_ik._solve_chunk``: world poses ``(N, 4, 4)`` -> verified branches
    ``(N, 8, 6)``. geometry: ``opw_ik._geometry``; offsets (rad), signs of the OPW form."""
    consts = (np.ascontiguousarray(pre, dtype=float), np.ascontiguousarray(post, dtype=float),
              geometry, offsets, signs, *link_constants(robot.links),
              np.ascontiguousarray(robot.base, dtype=float), np.ascontiguousarray(robot.tool, dtype=float),
              float(tol))

    def solve(T: np.ndarray) -> np.ndarray:
        out = np.empty((T.shape[0], 8, 6))
        _solve_kernel(np.ascontiguousarray(T, dtype=float), *consts, out)
        return out

    return solve
