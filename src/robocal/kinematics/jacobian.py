"""Analytic identification Jacobian d(TCP)/d(parameter) from the frames FK already computes.

A parameter that rotates about unit axis u through point o moves the TCP point p by u x (p - o)
and turns the TCP about u; one that translates along u moves p by u. Base and tool rotations are
the multiplicative increments of :meth:`Robot.displaced`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robocal.errors import ModelError
from robocal.kinematics.fk import LinkArrays, chain_frames


def motion_axes(links: LinkArrays, base: np.ndarray, tool: np.ndarray, q: np.ndarray):
    """TCP poses and, for every parameter, its motion axis.

    Returns ``tcp (N, 4, 4)``, ``u (N, P, 3)`` unit axes, ``o (N, P, 3)`` points on the axes and
    ``rotation (P,)`` bool, P = 5n + 12 in the order of :attr:`Robot.parameter_names`.
    For tool rotations o is the TCP itself (they turn the TCP without moving it).
    """
    tcp, frames = chain_frames(links, base, tool, q, frames=True)
    N, n = q.shape[0], q.shape[-1]
    P = 5 * n + 12
    u = np.empty((N, P, 3))
    o = np.zeros((N, P, 3))
    rotation = np.zeros(P, bool)
    x_prev, y_prev, z_prev = (frames[:, :n, :3, k] for k in range(3))
    o_prev = frames[:, :n, :3, 3]
    z_cur, o_cur = frames[:, 1:, :3, 2], frames[:, 1:, :3, 3]
    ca, sa = np.cos(links.alpha), np.sin(links.alpha)
    ax = np.broadcast_to(links.a, (N, n))[..., None]
    # alpha, a, beta, theta, d of link i at 5 i + (0..4)
    u[:, 0:5 * n:5], o[:, 0:5 * n:5] = x_prev, o_prev
    u[:, 1:5 * n:5] = x_prev
    u[:, 2:5 * n:5] = ca[..., None] * y_prev + sa[..., None] * z_prev
    o[:, 2:5 * n:5] = o_prev + ax * x_prev
    u[:, 3:5 * n:5], o[:, 3:5 * n:5] = z_cur, o_cur
    u[:, 4:5 * n:5] = z_cur
    rotation[0:5 * n:5] = rotation[2:5 * n:5] = rotation[3:5 * n:5] = True
    eye = np.broadcast_to(np.eye(3), (N, 3, 3))
    u[:, 5 * n : 5 * n + 3] = eye
    u[:, 5 * n + 3 : 5 * n + 6] = eye
    rotation[5 * n + 3 : 5 * n + 6] = True
    flange_axes = np.swapaxes(frames[:, n, :3, :3], -1, -2)  # rows: flange x, y, z in world
    u[:, 5 * n + 6 : 5 * n + 9] = flange_axes
    u[:, 5 * n + 9 :] = flange_axes
    o[:, 5 * n + 9 :] = tcp[:, None, :3, 3]
    rotation[5 * n + 9 :] = True
    return tcp, u, o, rotation


def robot_motion_axes(robot, q: np.ndarray, smr: np.ndarray | None = None):
    """:func:`motion_axes` for a robot, with the columns of its extra SMRs appended.

    ``smr`` ``(N,)`` is each row's SMR index (0 = the tool). An SMR's translation moves only
    the rows measured with it; the tool translation moves only the rows of SMR 0.
    """
    tools = robot.tool if smr is None else robot.tools_for(smr)
    tcp, u, o, rotation = motion_axes(robot.links, robot.base, tools, q)
    k = len(robot.smr)
    if k:
        n, N = robot.n_joints, q.shape[0]
        s = np.zeros(N, int) if smr is None else np.asarray(smr, int)
        flange = u[:, 5 * n + 6 : 5 * n + 9]
        active = s[:, None] == np.repeat(np.arange(1, k + 1), 3)[None, :]
        u_smr = np.tile(flange, (1, k, 1)) * active[..., None]
        u[:, 5 * n + 6 : 5 * n + 9] *= (s == 0)[:, None, None]
        u = np.concatenate([u, u_smr], axis=1)
        o = np.concatenate([o, np.zeros_like(u_smr)], axis=1)
        rotation = np.concatenate([rotation, np.zeros(3 * k, bool)])
    return tcp, u, o, rotation


def identification_jacobian(robot, q: np.ndarray, params: Sequence[str], kind: str = "point",
                            smr: np.ndarray | None = None):
    """d(TCP)/d(params) for joints ``q`` ``(N, n)`` (``smr`` ``(N,)``: each row's SMR index).

    kind 'point': ``(N, 3, k)`` position rows (m per m or m per rad);
    kind 'pose': ``(N, 6, k)`` position rows then orientation rows (rad per unit).
    """
    if kind not in ("point", "pose"):
        raise ModelError(f"unknown observation kind {kind!r}: use 'point' or 'pose'")
    idx = robot.indices(params)
    tcp, u, o, rotation = robot_motion_axes(robot, q, smr)
    return jacobian_from_axes(tcp, u[:, idx], o[:, idx], rotation[idx], kind)


def jacobian_from_axes(tcp, u, o, rotation, kind: str = "point") -> np.ndarray:
    """Assemble Jacobian rows ``(N, 3|6, k)`` from motion axes ``u, o (N, k, 3)``."""
    p = tcp[:, None, :3, 3]
    rot = rotation[None, :, None]
    dpos = np.where(rot, np.cross(u, p - o), u)
    if kind == "point":
        return np.swapaxes(dpos, 1, 2)
    dori = np.where(rot, u, 0.0)
    return np.swapaxes(np.concatenate([dpos, dori], axis=2), 1, 2)
