"""Forward kinematics of modified DH + beta chains, vectorised over poses and parameter sets.

Link i carries frame {i-1} to frame {i}:  T_i = Rx(alpha_i) Tx(a_i) Ry(beta_i) Rz(theta_i + q_i) Tz(d_i).
The chain is composed element-wise on component arrays (structure of arrays), which is several
times faster in numpy than stacked 4x4 matrix products.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

CHUNK = 65536  # poses per chunk: bounds peak memory for very large batches


class LinkArrays(NamedTuple):
    """Link parameters, each ``(..., n)``, in rad and m. Leading dims batch parameter sets."""

    alpha: np.ndarray
    a: np.ndarray
    beta: np.ndarray
    theta: np.ndarray
    d: np.ndarray


def _link_components(ca, sa, cb, sb, a, d, phi):
    """Rotation (9 arrays, row-major) and translation (3 arrays) of one link."""
    cp, sp = np.cos(phi), np.sin(phi)
    m00, m01, m02 = cb * cp, -cb * sp, sb
    m10, m11 = sp, cp
    m20, m21, m22 = -sb * cp, sb * sp, cb
    r = (
        m00, m01, m02,
        ca * m10 - sa * m20, ca * m11 - sa * m21, -sa * m22,
        sa * m10 + ca * m20, sa * m11 + ca * m21, ca * m22,
    )  # fmt: skip
    t = (a + d * r[2], d * r[5], d * r[8])
    return r, t


def _compose(R, t, r, s):
    """(R, t) <- (R, t) * (r, s) on component tuples."""
    R2 = tuple(
        R[3 * i] * r[j] + R[3 * i + 1] * r[3 + j] + R[3 * i + 2] * r[6 + j]
        for i in range(3)
        for j in range(3)
    )
    t2 = tuple(R[3 * i] * s[0] + R[3 * i + 1] * s[1] + R[3 * i + 2] * s[2] + t[i] for i in range(3))
    return R2, t2


def _to_matrix(R, t, shape):
    out = np.empty(shape + (4, 4))
    for i in range(3):
        for j in range(3):
            out[..., i, j] = R[3 * i + j]
        out[..., i, 3] = t[i]
    out[..., 3, :3] = 0.0
    out[..., 3, 3] = 1.0
    return out


def chain_frames(links: LinkArrays, base: np.ndarray, tool: np.ndarray, q: np.ndarray,
                 frames: bool = False):
    """Forward kinematics of a chain.

    links: link parameters ``(..., n)``; base, tool ``(..., 4, 4)``; q ``(..., n)`` joints (rad).
    All leading dims broadcast together (e.g. params ``(P, 1, n)`` with q ``(N, n)`` -> ``(P, N)``).
    Returns the TCP poses ``(..., 4, 4)``; with ``frames=True`` also the world poses of frames
    {0}..{n} as ``(..., n + 1, 4, 4)`` (frame {n} is the flange).
    """
    n = q.shape[-1]
    shape = np.broadcast_shapes(q.shape[:-1], links.alpha.shape[:-1], base.shape[:-2], tool.shape[:-2])
    base = np.broadcast_to(base, shape + (4, 4))
    R = tuple(base[..., i, j] for i in range(3) for j in range(3))
    t = tuple(base[..., i, 3] for i in range(3))
    saved = [(R, t)] if frames else None
    ca, sa = np.cos(links.alpha), np.sin(links.alpha)
    cb, sb = np.cos(links.beta), np.sin(links.beta)
    for j in range(n):
        r, s = _link_components(ca[..., j], sa[..., j], cb[..., j], sb[..., j],
                                links.a[..., j], links.d[..., j], links.theta[..., j] + q[..., j])
        R, t = _compose(R, t, r, s)
        if frames:
            saved.append((R, t))
    tool = np.broadcast_to(tool, shape + (4, 4))
    r = tuple(tool[..., i, j] for i in range(3) for j in range(3))
    s = tuple(tool[..., i, 3] for i in range(3))
    tcp = _to_matrix(*_compose(R, t, r, s), shape)
    if not frames:
        return tcp
    all_frames = np.empty(shape + (n + 1, 4, 4))
    for k, (Rk, tk) in enumerate(saved):
        all_frames[..., k, :, :] = _to_matrix(Rk, tk, shape)
    return tcp, all_frames


def chain_fk(links: LinkArrays, base: np.ndarray, tool: np.ndarray, q: np.ndarray) -> np.ndarray:
    """TCP poses ``(N, 4, 4)`` for joints ``(N, n)`` of one robot, in chunks to bound memory.

    ``tool`` is one ``(4, 4)`` frame or one per row ``(N, 4, 4)``."""
    N = q.shape[0]
    if N <= CHUNK:
        return chain_frames(links, base, tool, q)
    out = np.empty((N, 4, 4))
    per_row_tool = tool.ndim == 3
    for start in range(0, N, CHUNK):
        part = slice(start, start + CHUNK)
        out[part] = chain_frames(links, base, tool[part] if per_row_tool else tool, q[part])
    return out
