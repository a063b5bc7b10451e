"""Compiled (numba) twin of the identification Jacobian of :mod:`robocal.kinematics.jacobian` for
one robot without joint-error terms.

Imported only through :func:`robocal.kinematics.kernels.compiled` (numba is the optional ``fast``
extra). The same motion axes and the same formulas as :func:`~robocal.kinematics.jacobian.motion_axes`
and :func:`~robocal.kinematics.jacobian.jacobian_from_axes` (a rotation about unit axis u through o
moves the TCP point p by u x (p - o), a translation along u by u), computed pose by pose for the
requested columns only, from the frames of :func:`robocal.kinematics.fk_numba.chain_fk`: no
(3, parameters, poses) axis arrays. Cached on disk like the FK kernel.
"""

from __future__ import annotations

import numba
import numpy as np

from robocal.kinematics.fk import LinkArrays
from robocal.kinematics.fk_numba import chain_fk

_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@numba.njit(**_JIT)
def _columns(frames, tcp, ca, sa, a, idx, smr, n_smr, pose, out):
    """``out`` ``(N, 3|6, k)`` <- d(TCP)/d(parameter ``idx[c]``) for the parameters of
    :attr:`Robot.parameter_names` (links, base, tool, extra SMRs) from the world frames ``frames``
    ``(N, n + 1, 4, 4)`` and TCP poses ``tcp`` ``(N, 4, 4)``; ``smr`` ``(N,)`` each row's SMR."""
    N, n1 = frames.shape[0], frames.shape[1]
    n = n1 - 1
    L = 5 * n
    u = np.empty(3)
    o = np.empty(3)
    for i in range(N):
        F = frames[i]
        p0, p1, p2 = tcp[i, 0, 3], tcp[i, 1, 3], tcp[i, 2, 3]
        for c in range(idx.shape[0]):
            m = idx[c]
            rot = False
            active = True
            o[0] = o[1] = o[2] = 0.0
            if m < L:
                j, f = m // 5, m % 5
                for r in range(3):
                    if f == 0 or f == 1:  # alpha (rotation about x_{j-1}), a (along it)
                        u[r] = F[j, r, 0]
                        o[r] = F[j, r, 3]
                    elif f == 2:  # beta: about Rx(alpha) y_{j-1}, through o_{j-1} + a x_{j-1}
                        u[r] = ca[j] * F[j, r, 1] + sa[j] * F[j, r, 2]
                        o[r] = F[j, r, 3] + a[j] * F[j, r, 0]
                    else:  # theta (rotation about z_j), d (along it)
                        u[r] = F[j + 1, r, 2]
                        o[r] = F[j + 1, r, 3]
                rot = f == 0 or f == 2 or f == 3
            elif m < L + 6:  # base translation, rotation about the world axes through the origin
                k = (m - L) % 3
                u[0] = u[1] = u[2] = 0.0
                u[k] = 1.0
                rot = m >= L + 3
            elif m < L + 12:  # tool translation (rows of SMR 0), rotation about the TCP
                k = (m - L - 6) % 3
                for r in range(3):
                    u[r] = F[n, r, k]
                rot = m >= L + 9
                if rot:
                    o[0], o[1], o[2] = p0, p1, p2
                elif n_smr:
                    active = smr[i] == 0
            else:  # extra SMR s: translation along the flange axes, its own rows only
                k = (m - L - 12) % 3
                for r in range(3):
                    u[r] = F[n, r, k]
                active = smr[i] == 1 + (m - L - 12) // 3
            if not active:
                u[0] = u[1] = u[2] = 0.0
            if rot:
                d0, d1, d2 = p0 - o[0], p1 - o[1], p2 - o[2]
                out[i, 0, c] = u[1] * d2 - u[2] * d1
                out[i, 1, c] = u[2] * d0 - u[0] * d2
                out[i, 2, c] = u[0] * d1 - u[1] * d0
            else:
                out[i, 0, c], out[i, 1, c], out[i, 2, c] = u[0], u[1], u[2]
            if pose:
                for r in range(3):
                    out[i, 3 + r, c] = u[r] if rot else 0.0


def jacobian_rows(links: LinkArrays, base: np.ndarray, tools: np.ndarray, q: np.ndarray, idx: np.ndarray,
                  kind: str, smr: np.ndarray | None, n_smr: int) -> np.ndarray:
    """Identification Jacobian rows ``(N, 3|6, k)`` of parameters ``idx`` (indices into
    :attr:`Robot.parameter_names`, links, frames and extra SMRs only) of one robot (links ``(n,)``,
    base ``(4, 4)``, ``tools`` ``(4, 4)`` or one per row) at joints ``q`` ``(N, n)`` (the joints
    it reaches); ``smr`` ``(N,)`` each row's SMR index, ``n_smr`` the robot's extra SMRs."""
    tcp, frames = chain_fk(links, base, tools, q, frames=True)
    N = q.shape[0]
    out = np.empty((N, 3 if kind == "point" else 6, idx.size))
    rows_smr = np.zeros(N, np.int64) if smr is None else np.ascontiguousarray(smr, dtype=np.int64)
    a, columns = np.ascontiguousarray(links.a, dtype=float), np.ascontiguousarray(idx, dtype=np.int64)
    _columns(frames, tcp, np.cos(links.alpha), np.sin(links.alpha), a, columns, rows_smr, n_smr,
             kind == "pose", out)
    return out
