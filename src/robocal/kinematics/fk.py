"""Forward kinematics of modified DH + beta chains, vectorised over poses and parameter sets.

Link i carries frame {i-1} to frame {i}:  T_i = Rx(alpha_i) Tx(a_i) Ry(beta_i) Rz(theta_i + q_i) Tz(d_i).
The chain is composed element-wise on component arrays (structure of arrays), which is several
times faster in numpy than stacked 4x4 matrix products. One robot with a batch of joints (the
common case) takes a faster path: cache-sized chunks, the frame kept as four (3, M) column blocks,
the link's constant rotations Rx(alpha) Ry(beta) applied as scalar column mixes (skipped or turned
into a column swap when alpha, beta are 0 or multiples of pi/2) and sin/cos of every joint from
one vectorised polynomial evaluation per chunk. With the optional numba extra in use, the TCP
poses (and frames) of that path come from its compiled twin, :mod:`robocal.kinematics.fk_numba`
(see :mod:`robocal.kinematics.kernels`: a small call does not import numba by itself).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from robocal.kinematics.kernels import compiled

# poses per chunk wherever a computation over poses holds per-pose temporaries (the general FK
# path, the identification Jacobian, normal equations, streamed files): bounds their peak memory
CHUNK = 4096
FAST_CHUNK = 4096  # poses per chunk of the one-robot path: its temporaries stay in the CPU cache


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


def prismatic_split(links: LinkArrays, q: np.ndarray,
                    prismatic: np.ndarray | None) -> tuple[LinkArrays, np.ndarray]:
    """Move the values of prismatic joints into d: links with ``d + q`` ``(..., n)`` there and
    joints with 0 there, so that the revolute formulas compute the chain with prismatic joints
    (``prismatic`` ``(n,)`` bool; None or all False: unchanged)."""
    if prismatic is None or not np.any(prismatic):
        return links, q
    mask = np.asarray(prismatic, bool)
    d = links.d + np.where(mask, q, 0.0)
    return links._replace(d=d), np.where(mask, 0.0, q)


def chain_frames(links: LinkArrays, base: np.ndarray, tool: np.ndarray, q: np.ndarray,
                 frames: bool = False, prismatic: np.ndarray | None = None):
    """Forward kinematics of a chain.

    links: link parameters ``(..., n)``; base, tool ``(..., 4, 4)``; q ``(..., n)`` joints (rad for
    a revolute joint, m for a prismatic one, which adds to d: ``prismatic`` ``(n,)`` bool).
    All leading dims broadcast together (e.g. params ``(P, 1, n)`` with q ``(N, n)`` -> ``(P, N)``).
    Returns the TCP poses ``(..., 4, 4)``; with ``frames=True`` also the world poses of frames
    {0}..{n} as ``(..., n + 1, 4, 4)`` (frame {n} is the flange). A chain with prismatic joints
    runs the general numpy path (its d varies per pose; the one-robot fast paths need constant links).
    """
    links, q = prismatic_split(links, q, prismatic)
    if _fast_ok(links, base, tool, q):
        kernel = compiled("robocal.kinematics.fk_numba", q.shape[0])
        if kernel is not None:
            return kernel.chain_fk(links, base, tool, q, frames)
        return _fast_chain(links, base, tool, q, frames)
    n = q.shape[-1]
    shape = np.broadcast_shapes(q.shape[:-1], links.alpha.shape[:-1], links.d.shape[:-1], base.shape[:-2],
                                tool.shape[:-2])
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


def chain_fk(links: LinkArrays, base: np.ndarray, tool: np.ndarray, q: np.ndarray,
             prismatic: np.ndarray | None = None) -> np.ndarray:
    """TCP poses ``(N, 4, 4)`` for joints ``(N, n)`` of one robot, in chunks to bound memory.

    ``tool`` is one ``(4, 4)`` frame or one per row ``(N, 4, 4)``; ``prismatic`` as in
    :func:`chain_frames`."""
    N = q.shape[0]
    if N <= CHUNK or _fast_ok(links, base, tool, q) and not np.any(prismatic):
        return chain_frames(links, base, tool, q, prismatic=prismatic)
    out = np.empty((N, 4, 4))
    per_row_tool = tool.ndim == 3
    for start in range(0, N, CHUNK):
        part = slice(start, start + CHUNK)
        out[part] = chain_frames(links, base, tool[part] if per_row_tool else tool, q[part],
                                 prismatic=prismatic)
    return out


def _fast_ok(links: LinkArrays, base: np.ndarray, tool: np.ndarray, q: np.ndarray) -> bool:
    """One robot (links ``(n,)``, base ``(4, 4)``), joints ``(N, n)``, one tool or one per row."""
    return (q.ndim == 2 and links.alpha.ndim == 1 and base.shape == (4, 4)
            and all(np.ndim(v) == 1 for v in links)
            and (tool.shape == (4, 4) or tool.shape == (q.shape[0], 4, 4)))


# sin/cos by reduction modulo pi (Cody-Waite: P1 has 33 significant bits, so n * P1 is exact for
# |n| < 2**20) and Taylor polynomials on [-pi/2, pi/2] to r**21 / r**22 (truncation < 3e-16).
# In numpy this is about 4x as fast as np.sin + np.cos (libm, not vectorised; bench_fk prints the
# ratio on a 6 x FAST_CHUNK block) and agrees with them to 3e-16; used while |angle| <= _POLY_MAX.
_P1 = 2 * 1.57079632673412561417e00
_P1T = 2 * 6.07710050650619224932e-11
_SIN = [(-1) ** k / math.factorial(2 * k + 1) for k in range(1, 11)]
_COS = [(-1) ** k / math.factorial(2 * k) for k in range(2, 12)]
_POLY_MAX = 1e5
_RESIDUE = 1e-15  # |cos|, |sin| of a link's constant angle below this are rounding residue: 0


def _sin_cos(x: np.ndarray, c: np.ndarray, s: np.ndarray, work: np.ndarray) -> None:
    """c, s <- cos(x), sin(x) for |x| <= _POLY_MAX; ``work`` is ``(4,) + x.shape`` scratch."""
    n, r, z, p = work
    np.multiply(x, 1 / np.pi, out=n)
    np.rint(n, out=n)
    np.multiply(n, _P1, out=r)
    np.subtract(x, r, out=r)
    np.multiply(n, _P1T, out=z)
    np.subtract(r, z, out=r)  # x = n pi + r, |r| <= pi/2
    np.multiply(r, r, out=z)
    np.multiply(z, _SIN[-1], out=p)
    for coef in _SIN[-2::-1]:
        np.add(p, coef, out=p)
        np.multiply(p, z, out=p)
    np.multiply(p, r, out=p)
    np.add(p, r, out=s)
    np.multiply(z, _COS[-1], out=p)
    for coef in _COS[-2::-1]:
        np.add(p, coef, out=p)
        np.multiply(p, z, out=p)
    np.multiply(p, z, out=p)
    np.multiply(z, 0.5, out=z)
    np.subtract(p, z, out=p)
    np.add(p, 1.0, out=c)
    np.multiply(n, 0.5, out=z)  # (-1)**n = 1 - 4 frac(n / 2)
    np.floor(z, out=p)
    np.subtract(z, p, out=z)
    np.multiply(z, -4.0, out=z)
    np.add(z, 1.0, out=z)
    np.multiply(s, z, out=s)
    np.multiply(c, z, out=c)


def _cos_sin(angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """cos, sin of ``angles`` (rad) with the 1e-17 residue at multiples of pi/2 removed (so those
    become swaps)."""
    c, s = np.cos(angles), np.sin(angles)
    return np.where(np.abs(c) < _RESIDUE, 0.0, c), np.where(np.abs(s) < _RESIDUE, 0.0, s)


class _Frame:
    """A chunk's frame as column blocks ``x[k]`` ``(3, m)`` with lazy signs: the rotation's column
    k is ``sign[k] * x[k]`` (quarter turns about x or y then cost a swap, not arithmetic);
    ``x[3]`` is the translation, ``t1``, ``t2`` scratch blocks."""

    def __init__(self, blocks: list) -> None:
        self.x = blocks[:4]
        self.t1, self.t2 = blocks[4], blocks[5]
        self.sign = [1.0, 1.0, 1.0]

    def translate(self, k: int, dist: float) -> None:
        """t += dist * column k."""
        if dist != 0.0:
            np.multiply(self.x[k], dist * self.sign[k], out=self.t1)
            np.add(self.x[3], self.t1, out=self.x[3])

    def turn(self, i: int, j: int, c: float, s: float) -> None:
        """Columns (i, j) <- (c col_i + s col_j, c col_j - s col_i), scalar c, s."""
        x, sg = self.x, self.sign
        if s == 0.0:
            if c < 0:
                sg[i], sg[j] = -sg[i], -sg[j]
        elif c == 0.0:
            x[i], x[j] = x[j], x[i]
            sg[i], sg[j] = s * sg[j], -s * sg[i]
        else:
            np.multiply(x[j], s * sg[j], out=self.t1)
            np.multiply(x[i], s * sg[i], out=self.t2)
            np.multiply(x[i], c * sg[i], out=x[i])
            np.add(x[i], self.t1, out=x[i])
            np.multiply(x[j], c * sg[j], out=x[j])
            np.subtract(x[j], self.t2, out=x[j])
            sg[i] = sg[j] = 1.0

    def joint(self, c: np.ndarray, s: np.ndarray) -> None:
        """Columns (0, 1) <- (c col_0 + s col_1, c col_1 - s col_0), arrays c, s ``(m,)``."""
        x0, x1, t1, t2 = self.x[0], self.x[1], self.t1, self.t2
        np.multiply(x1, s, out=t1)
        np.multiply(x0, s, out=t2)
        np.multiply(x0, c, out=x0)
        np.multiply(x1, c, out=x1)
        if self.sign[0] == self.sign[1]:
            np.add(x0, t1, out=x0)
            np.subtract(x1, t2, out=x1)
        else:
            np.subtract(x0, t1, out=x0)
            np.add(x1, t2, out=x1)

    def set(self, R: np.ndarray, t: np.ndarray, c: np.ndarray, s: np.ndarray) -> None:
        """The frame (R, t) * Rz(phi) for constant R, t and arrays cos, sin of phi."""
        x = self.x
        np.multiply(R[:, 0, None], c, out=x[0])
        np.multiply(R[:, 1, None], s, out=self.t1)
        np.add(x[0], self.t1, out=x[0])
        np.multiply(R[:, 1, None], c, out=x[1])
        np.multiply(R[:, 0, None], s, out=self.t1)
        np.subtract(x[1], self.t1, out=x[1])
        x[2][:] = R[:, 2, None]
        x[3][:] = t[:, None]
        self.sign = [1.0, 1.0, 1.0]

    def apply_tool(self, tool: np.ndarray, rot_identity: bool) -> None:
        """(R, t) <- (R, t) * tool, tool ``(4, 4)`` or ``(m, 4, 4)``."""
        x, sg = self.x, self.sign
        for k in range(3):
            w = tool[..., k, 3]
            if np.ndim(w):
                np.multiply(x[k], w, out=self.t1)
                (np.add if sg[k] > 0 else np.subtract)(x[3], self.t1, out=x[3])
            else:
                self.translate(k, float(w))
        if rot_identity:
            return
        new = []
        for jj in range(3):
            acc = np.multiply(x[0], tool[..., 0, jj] * sg[0])
            for k in (1, 2):
                np.multiply(x[k], tool[..., k, jj] * sg[k], out=self.t1)
                np.add(acc, self.t1, out=acc)
            new.append(acc)
        for jj in range(3):
            x[jj][:] = new[jj]
        self.sign = [1.0, 1.0, 1.0]

    def store(self, dest: np.ndarray) -> None:
        """Write into ``dest`` ``(m, 4, 4)`` (its last row is set by the caller)."""
        for k in range(4):
            if k < 3 and self.sign[k] < 0:
                np.negative(self.x[k].T, out=dest[:, :3, k])
            else:
                dest[:, :3, k] = self.x[k].T


def _rx_ry(R: np.ndarray, ca: float, sa: float, cb: float, sb: float) -> np.ndarray:
    return R @ np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]]) @ np.array([[cb, 0, sb], [0, 1, 0],
                                                                             [-sb, 0, cb]])


def _fast_chain(links: LinkArrays, base: np.ndarray, tool: np.ndarray, q: np.ndarray, frames: bool):
    """The one-robot path of :func:`chain_frames` (same results, same shapes)."""
    N, n = q.shape
    out = np.empty((N, 4, 4))
    out[:, 3, :] = (0.0, 0.0, 0.0, 1.0)
    saved = None
    if frames:
        saved = np.empty((N, n + 1, 4, 4))
        saved[:, :, 3, :] = (0.0, 0.0, 0.0, 1.0)
        saved[:, 0] = base
    alpha_cs = np.stack(_cos_sin(links.alpha), axis=1).tolist()  # [[cos, sin], ...] as floats
    beta_cs = np.stack(_cos_sin(links.beta), axis=1).tolist()
    a, d, theta = (np.asarray(v, dtype=float) for v in (links.a, links.d, links.theta))
    # joint 1 starts from a constant frame: base * Rx(alpha1) Tx(a1) Ry(beta1)
    R1 = _rx_ry(base[:3, :3], *alpha_cs[0], *beta_cs[0])
    t1 = base[:3, 3] + a[0] * base[:3, 0] + d[0] * R1[:, 2]  # Rz(q1) moves neither
    per_row_tool = tool.ndim == 3
    tool_rot_identity = not per_row_tool and np.array_equal(tool[:3, :3], np.eye(3))
    M = max(min(N, FAST_CHUNK), 1)  # N = 0 gives empty results
    blocks = np.empty((6, 3, M))
    phi, cph, sph = np.empty((n, M)), np.empty((n, M)), np.empty((n, M))
    work = np.empty((4, n, M))
    poly = N * n > 0 and max(q.max(), -q.min()) + np.abs(theta).max() <= _POLY_MAX
    for start in range(0, N, M):
        m = min(M, N - start)
        rows = slice(start, start + m)
        np.add(q[rows].T, theta[:, None], out=phi[:, :m])
        if poly:
            _sin_cos(phi[:, :m], cph[:, :m], sph[:, :m], work[:, :, :m])
        else:
            np.cos(phi[:, :m], out=cph[:, :m])
            np.sin(phi[:, :m], out=sph[:, :m])
        f = _Frame([blocks[k, :, :m] for k in range(6)])
        f.set(R1, t1, cph[0, :m], sph[0, :m])
        for j in range(1, n):
            if frames:
                f.store(saved[rows, j])
            f.translate(0, a[j])
            f.turn(1, 2, *alpha_cs[j])  # Rx(alpha)
            f.turn(2, 0, *beta_cs[j])  # Ry(beta)
            f.joint(cph[j, :m], sph[j, :m])  # Rz(theta + q)
            f.translate(2, d[j])
        if frames:
            f.store(saved[rows, n])
        f.apply_tool(tool[rows] if per_row_tool else tool, tool_rot_identity)
        f.store(out[rows])
    return (out, saved) if frames else out
