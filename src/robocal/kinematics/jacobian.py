"""Analytic identification Jacobian d(TCP)/d(parameter) from the frames FK already computes.

A parameter that rotates about unit axis u through point o moves the TCP point p by u x (p - o)
and turns the TCP about u; one that translates along u moves p by u. Base and tool rotations are
the multiplicative increments of :meth:`Robot.displaced`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robocal.core.errors import ModelError
from robocal.kinematics.conditions import UNKNOWN, Conditions
from robocal.kinematics.fk import CHUNK, LinkArrays, chain_frames
from robocal.kinematics.joint_errors import conditions_of, joint_error_basis, scatter_offsets
from robocal.kinematics.kernels import compiled
from robocal.kinematics.thermal import is_name as is_thermal
from robocal.kinematics.thermal import link_mask, scaled_links, translation_axis


def motion_axes(links: LinkArrays, base: np.ndarray, tool: np.ndarray, q: np.ndarray,
                prismatic: np.ndarray | None = None):
    """TCP poses and, for every parameter, its motion axis, component-major for speed.

    Returns ``tcp (N, 4, 4)``, ``u (3, P, N)`` unit axes, ``o (3, P, N)`` points on the axes and
    ``rotation (P,)`` bool, P = 5n + 12 in the order of :attr:`Robot.parameter_names`.
    For tool rotations o is the TCP itself (they turn the TCP without moving it). A prismatic
    joint (``prismatic`` ``(n,)`` bool) changes nothing here: its value adds to d, whose axis is
    z_i either way.
    """
    tcp, frames = chain_frames(links, base, tool, q, frames=True, prismatic=prismatic)
    N, n = q.shape[0], q.shape[-1]
    F = np.ascontiguousarray(frames.transpose(2, 3, 1, 0))  # (4, 4, n + 1, N): row, column, frame
    P = 5 * n + 12
    u = np.empty((3, P, N))
    o = np.zeros((3, P, N))
    rotation = np.zeros(P, bool)
    x_prev, y_prev, z_prev, o_prev = (F[:3, c, :n] for c in range(4))  # (3, n, N)
    z_cur, o_cur = F[:3, 2, 1:], F[:3, 3, 1:]
    ca = np.cos(links.alpha)[:, None]
    sa = np.sin(links.alpha)[:, None]
    a = np.asarray(links.a, float).T  # (n, 1) or, with per-pose (thermal) links, (n, N)
    a = a[:, None] if a.ndim == 1 else a
    L = 5 * n  # alpha, a, beta, theta, d of link i at 5 i + (0..4)
    u[:, 0:L:5], o[:, 0:L:5] = x_prev, o_prev
    u[:, 1:L:5] = x_prev
    u[:, 2:L:5] = ca * y_prev + sa * z_prev
    o[:, 2:L:5] = o_prev + a * x_prev
    u[:, 3:L:5], o[:, 3:L:5] = z_cur, o_cur
    u[:, 4:L:5] = z_cur
    rotation[0:L:5] = rotation[2:L:5] = rotation[3:L:5] = True
    eye = np.eye(3)[:, :, None]
    u[:, L : L + 3] = eye
    u[:, L + 3 : L + 6] = eye
    rotation[L + 3 : L + 6] = True
    flange = F[:3, :3, n]  # (3 components, 3 axes, N)
    u[:, L + 6 : L + 9] = flange
    u[:, L + 9 :] = flange
    o[:, L + 9 :] = tcp[:, :3, 3].T[:, None]
    rotation[L + 9 :] = True
    return tcp, u, o, rotation


def robot_motion_axes(robot, q: np.ndarray, smr: np.ndarray | None = None, conditions: Conditions = UNKNOWN):
    """:func:`motion_axes` for a robot, with the columns of its extra SMRs and of its joint-error
    terms appended (the order of :attr:`Robot.parameter_names`).

    ``smr`` ``(N,)`` is each row's SMR index (0 = the tool). An SMR's translation moves only
    the rows measured with it; the tool translation moves only the rows of SMR 0. The axes are
    those at the joints the robot really reaches (``robot.reached_joints``, as in ``fk``; the
    small dependence of the joint errors on the link parameters is second order and left out).
    A joint-error parameter p of joint i turns the TCP about axis i by B_p(q) per unit
    (:func:`joint_error_basis`): its axis is joint i's scaled by B_p, pose by pose; on a prismatic
    joint it moves the TCP along axis i (the d_i column scaled by B_p). A thermal parameter
    (shared or a link group's) translates the TCP (`robocal.kinematics.thermal.translation_axis`); with
    it, every axis is that of the links scaled at the ``conditions``' temperature ``(N,)``, and the
    link-length columns are per unit of the unscaled length (the scaled one's times the link's scale).
    """
    tools = robot.tool if smr is None else robot.tools_for(smr)
    conditions = conditions_of(robot, q.shape[0], conditions)
    temperature = conditions.temperature
    if robot.joint_errors is None:
        reached = q
    else:  # the basis once: for the reached joints (as robot.reached_joints) and the axes
        B, joint = joint_error_basis(robot, q, robot.joint_errors.names, conditions)  # (N, m), (m,)
        reached = q + scatter_offsets(B, joint, robot.joint_errors.values, robot.n_joints)
    scale = robot.link_scale(temperature)  # (N, n) or None
    tcp, u, o, rotation = motion_axes(scaled_links(robot.links, scale), robot.base, tools, reached,
                                      robot.prismatic)
    k = len(robot.smr)
    if k:
        L = 5 * robot.n_joints
        s = np.zeros(q.shape[0], int) if smr is None else np.asarray(smr, int)
        flange = u[:, L + 6 : L + 9]
        active = s[None, :] == np.repeat(np.arange(1, k + 1), 3)[:, None]  # (3k, N)
        u_smr = np.tile(flange, (1, k, 1)) * active
        u[:, L + 6 : L + 9] *= s == 0
        u = np.concatenate([u, u_smr], axis=1)
        o = np.concatenate([o, np.zeros_like(u_smr)], axis=1)
        rotation = np.concatenate([rotation, np.zeros(3 * k, bool)])
    if robot.joint_errors is not None:
        slides = robot.prismatic[joint]
        column = 5 * joint + np.where(slides, 4, 3)  # d_i of a prismatic joint, else theta_i
        u_err, turn = u[:, column] * B.T, ~slides
        for t, name in enumerate(robot.joint_errors.names):
            if is_thermal(name):
                u_err[:, t] = translation_axis(u[:, : 5 * robot.n_joints], robot.links, temperature,
                                               robot.joint_errors.reference_temperature_c,
                                               link_mask(name, robot.prismatic))
                turn[t] = False
        u = np.concatenate([u, u_err], axis=1)
        o = np.concatenate([o, o[:, column]], axis=1)
        rotation = np.concatenate([rotation, turn])
    if scale is not None:  # d(a_i s_i)/d(a_i) = s_i (after the joint-error and thermal axes used u)
        L = 5 * robot.n_joints
        u[:, 1:L:5] *= scale.T
        u[:, 4:L:5] *= scale.T
    return tcp, u, o, rotation


def identification_jacobian(robot, q: np.ndarray, params: Sequence[str], kind: str = "point",
                            smr: np.ndarray | None = None, conditions: Conditions = UNKNOWN):
    """d(TCP)/d(params) for joints ``q`` ``(N, n)`` (``smr`` ``(N,)``: each row's SMR index;
    ``conditions``: the rows' approach directions, moves, payloads and temperatures, for the
    backlash, travel, payload and thermal terms).

    kind 'point': ``(N, 3, k)`` position rows (m per m or m per rad);
    kind 'pose': ``(N, 6, k)`` position rows then orientation rows (rad per unit).
    Computed in chunks of :data:`robocal.kinematics.fk.CHUNK` poses (every row depends on its own
    pose only), so the temporaries (every parameter's motion axis, ~15 kB per pose) stay bounded.
    """
    if kind not in ("point", "pose"):
        raise ModelError(f"unknown observation kind {kind!r}: use 'point' or 'pose'")
    idx = robot.indices(params)
    N = q.shape[0]
    if N <= CHUNK:
        return _jacobian_rows(robot, q, idx, kind, smr, conditions)
    out = np.empty((N, 3 if kind == "point" else 6, idx.size))
    for start in range(0, N, CHUNK):
        part = slice(start, start + CHUNK)
        out[part] = _jacobian_rows(robot, q[part], idx, kind, None if smr is None else np.asarray(smr)[part],
                                   conditions.rows(part))
    return out


def _jacobian_rows(robot, q, idx: np.ndarray, kind: str, smr, conditions: Conditions) -> np.ndarray:
    if robot.joint_errors is None and not np.any(robot.prismatic):  # one chain: the compiled twin, if in use
        kernel = compiled("robocal.kinematics.jacobian_numba", q.shape[0])
        if kernel is not None:
            one_tool = smr is None or not len(robot.smr) and not np.any(smr)  # every row SMR 0
            tools = robot.tool if one_tool else robot.tools_for(smr)
            return kernel.jacobian_rows(robot.links, robot.base, tools, q, idx, kind, smr, len(robot.smr))
    tcp, u, o, rotation = robot_motion_axes(robot, q, smr, conditions)
    return jacobian_from_axes(tcp, u[:, idx], o[:, idx], rotation[idx], kind)


def jacobian_from_axes(tcp, u, o, rotation, kind: str = "point") -> np.ndarray:
    """Assemble Jacobian rows ``(N, 3|6, k)`` from motion axes ``u, o (3, k, N)``: the cross
    products for the rotation columns only, written straight into the rows' layout."""
    k, N = u.shape[1], u.shape[2]
    out = np.empty((N, 3 if kind == "point" else 6, k))
    view = out.transpose(1, 2, 0)  # (rows, k, N)
    rot, move = np.flatnonzero(rotation), np.flatnonzero(~rotation)
    view[:3, move] = u[:, move]
    ur = u[:, rot]
    d = tcp[:, :3, 3].T[:, None] - o[:, rot]  # (3, r, N)
    view[0, rot] = ur[1] * d[2] - ur[2] * d[1]
    view[1, rot] = ur[2] * d[0] - ur[0] * d[2]
    view[2, rot] = ur[0] * d[1] - ur[1] * d[0]
    if kind == "pose":
        view[3:, rot] = ur
        view[3:, move] = 0.0
    return out
