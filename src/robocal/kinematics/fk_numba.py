"""Compiled (numba) twin of the one-robot forward-kinematics path of :mod:`robocal.kinematics.fk`.

Imported only through :func:`robocal.kinematics.kernels.compiled` (numba is the optional ``fast``
extra). Same formulas and the same sin/cos polynomial as the numpy path: poses go through in
blocks of ``BLOCK``, the frames of a block held as 12 rows (the top 3x4 of each pose, row-major)
so that every loop over poses is a plain vectorisable loop; the constant part of each link,
Rx(alpha) Ry(beta), is one 3x3 matrix. :func:`chain_block` is shared with the closed-form IK
kernel, which verifies its solutions with it. Compiled on first use and cached on disk
(``__pycache__``). numba's cache is keyed on each kernel's own source file only: after editing the
constants taken from fk.py, or this file, delete the ``*.nbi``/``*.nbc`` files of this folder and of
``robocal/ik/__pycache__`` (the IK kernel compiles :func:`chain_block` into itself).
"""

from __future__ import annotations

import numba
import numpy as np

from robocal.kinematics.fk import _COS, _P1, _P1T, _POLY_MAX, _SIN, LinkArrays, _cos_sin

BLOCK = 512  # poses per block: the block's rows stay in the L1/L2 cache
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}
S1, S2, S3, S4, S5, S6, S7, S8, S9, S10 = _SIN
C1, C2, C3, C4, C5, C6, C7, C8, C9, C10 = _COS


@numba.njit
def cos_sin(x: float) -> tuple[float, float]:
    """cos(x), sin(x) for |x| <= _POLY_MAX: the polynomial of ``fk._sin_cos``, one value."""
    n = np.rint(x * (1 / np.pi))
    r = (x - n * _P1) - n * _P1T  # x = n pi + r, |r| <= pi/2
    z = r * r
    p = ((((((((S10 * z + S9) * z + S8) * z + S7) * z + S6) * z + S5) * z + S4) * z + S3) * z + S2) * z + S1
    s = r + p * z * r
    p = ((((((((C10 * z + C9) * z + C8) * z + C7) * z + C6) * z + C5) * z + C4) * z + C3) * z + C2) * z + C1
    c = (p * z * z - z * 0.5) + 1.0
    half = n * 0.5
    sign = 1.0 - 4.0 * (half - np.floor(half))  # (-1)**n
    return c * sign, s * sign


@numba.njit(**_JIT)
def chain_block(phi, m, A, a, d, base, c, s, F):
    """``F[:, :m]`` <- base * T_1 ... T_n for joint angles (theta + q) ``phi[:, :m]`` ``(n, M)``.

    T_j = Tx(a_j) A_j Rz(phi_j) Tz(d_j) with A_j = Rx(alpha_j) Ry(beta_j) ``(n, 3, 3)``; F rows
    are r00 r01 r02 t0 r10 r11 r12 t1 r20 r21 r22 t2; ``c``, ``s`` ``(n, M)`` are scratch."""
    n = phi.shape[0]
    small = True
    for j in range(n):
        for i in range(m):
            small &= abs(phi[j, i]) <= _POLY_MAX
    for j in range(n):
        if small:
            for i in range(m):
                c[j, i], s[j, i] = cos_sin(phi[j, i])
        else:
            for i in range(m):
                c[j, i], s[j, i] = np.cos(phi[j, i]), np.sin(phi[j, i])
    for k in range(12):
        v = base[k // 4, k % 4]
        for i in range(m):
            F[k, i] = v
    for j in range(n):
        aj, dj = a[j], d[j]
        A00, A01, A02 = A[j, 0, 0], A[j, 0, 1], A[j, 0, 2]
        A10, A11, A12 = A[j, 1, 0], A[j, 1, 1], A[j, 1, 2]
        A20, A21, A22 = A[j, 2, 0], A[j, 2, 1], A[j, 2, 2]
        for row in range(3):
            x0, x1, x2, tr = F[4 * row], F[4 * row + 1], F[4 * row + 2], F[4 * row + 3]
            for i in range(m):
                r0, r1, r2 = x0[i], x1[i], x2[i]
                b0 = r0 * A00 + r1 * A10 + r2 * A20
                b1 = r0 * A01 + r1 * A11 + r2 * A21
                b2 = r0 * A02 + r1 * A12 + r2 * A22
                ci, si = c[j, i], s[j, i]
                tr[i] += aj * r0 + dj * b2
                x0[i] = ci * b0 + si * b1
                x1[i] = ci * b1 - si * b0
                x2[i] = b2


@numba.njit(**_JIT)
def _fk_kernel(q, theta, A, a, d, base, tool, out):
    """``out`` ``(N, 4, 4)`` <- TCP poses of joints ``q`` ``(N, n)``; tool ``(1 | N, 4, 4)``."""
    N, n = q.shape
    M = min(BLOCK, max(N, 1))
    phi, c, s, F = np.empty((n, M)), np.empty((n, M)), np.empty((n, M)), np.empty((12, M))
    per_row = tool.shape[0] > 1
    for start in range(0, N, M):
        m = min(M, N - start)
        for j in range(n):
            for i in range(m):
                phi[j, i] = q[start + i, j] + theta[j]
        chain_block(phi, m, A, a, d, base, c, s, F)
        for i in range(m):
            E = tool[start + i] if per_row else tool[0]
            o = out[start + i]
            for row in range(3):
                x0, x1, x2 = F[4 * row, i], F[4 * row + 1, i], F[4 * row + 2, i]
                for col in range(4):
                    o[row, col] = x0 * E[0, col] + x1 * E[1, col] + x2 * E[2, col]
                o[row, 3] += F[4 * row + 3, i]
            o[3, 0], o[3, 1], o[3, 2], o[3, 3] = 0.0, 0.0, 0.0, 1.0


@numba.njit(**_JIT)
def _frames_kernel(q, theta, A, a, d, base, tool, out, frames):
    """``out`` ``(N, 4, 4)`` <- TCP poses and ``frames`` ``(N, n + 1, 4, 4)`` <- the world poses of
    frames {0}..{n} of joints ``q`` ``(N, n)``; tool ``(1 | N, 4, 4)``. Pose by pose, the chain of
    :func:`chain_block` (same formulas, same sin/cos) with every frame stored."""
    N, n = q.shape
    per_row = tool.shape[0] > 1
    R = np.empty((3, 4))
    for i in range(N):
        for row in range(3):
            for col in range(4):
                R[row, col] = base[row, col]
        F = frames[i]
        for j in range(n + 1):
            if j:
                x = q[i, j - 1] + theta[j - 1]
                if abs(x) <= _POLY_MAX:
                    c, s = cos_sin(x)
                else:
                    c, s = np.cos(x), np.sin(x)
                Aj, aj, dj = A[j - 1], a[j - 1], d[j - 1]
                for row in range(3):
                    r0, r1, r2 = R[row, 0], R[row, 1], R[row, 2]
                    b0 = r0 * Aj[0, 0] + r1 * Aj[1, 0] + r2 * Aj[2, 0]
                    b1 = r0 * Aj[0, 1] + r1 * Aj[1, 1] + r2 * Aj[2, 1]
                    b2 = r0 * Aj[0, 2] + r1 * Aj[1, 2] + r2 * Aj[2, 2]
                    R[row, 3] += aj * r0 + dj * b2
                    R[row, 0] = c * b0 + s * b1
                    R[row, 1] = c * b1 - s * b0
                    R[row, 2] = b2
            for row in range(3):
                for col in range(4):
                    F[j, row, col] = R[row, col]
            F[j, 3, 0], F[j, 3, 1], F[j, 3, 2], F[j, 3, 3] = 0.0, 0.0, 0.0, 1.0
        E = tool[i] if per_row else tool[0]
        o = out[i]
        for row in range(3):
            for col in range(4):
                o[row, col] = R[row, 0] * E[0, col] + R[row, 1] * E[1, col] + R[row, 2] * E[2, col]
            o[row, 3] += R[row, 3]
        o[3, 0], o[3, 1], o[3, 2], o[3, 3] = 0.0, 0.0, 0.0, 1.0


def link_constants(links: LinkArrays) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``theta, A, a, d`` of one robot for :func:`chain_block` (A_j = Rx(alpha_j) Ry(beta_j), with
    the rounding residue at multiples of 90 deg removed as in the numpy path)."""
    ca, sa = _cos_sin(links.alpha)
    cb, sb = _cos_sin(links.beta)
    zero = np.zeros_like(ca)
    A = np.stack([cb, zero, sb, sa * sb, ca, -sa * cb, -ca * sb, sa, ca * cb], axis=-1).reshape(-1, 3, 3)
    theta, a, d = (np.ascontiguousarray(v, dtype=float) for v in (links.theta, links.a, links.d))
    return theta, A, a, d


def chain_fk(links: LinkArrays, base: np.ndarray, tool: np.ndarray, q: np.ndarray, frames: bool = False):
    """TCP poses ``(N, 4, 4)`` of one robot (links ``(n,)``, base ``(4, 4)``) for joints ``(N, n)``,
    tool ``(4, 4)`` or ``(N, 4, 4)``: the compiled :func:`robocal.kinematics.fk.chain_fk`; with
    ``frames=True`` also the world poses of frames {0}..{n} ``(N, n + 1, 4, 4)`` (as
    :func:`robocal.kinematics.fk.chain_frames`)."""
    q = np.ascontiguousarray(q, dtype=float)
    out = np.empty((q.shape[0], 4, 4))
    args = (q, *link_constants(links), np.ascontiguousarray(base, dtype=float),
            np.ascontiguousarray(tool, dtype=float).reshape(-1, 4, 4), out)
    if not frames:
        _fk_kernel(*args)
        return out
    saved = np.empty((q.shape[0], q.shape[1] + 1, 4, 4))
    _frames_kernel(*args, saved)
    return out, saved
