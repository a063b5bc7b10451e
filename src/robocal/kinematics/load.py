"""Payload compliance: the joints deflect under the gravity moment of the payload.

The payload is a point mass ``m`` (kg) at its centre of mass ``c`` (m, in the flange frame tool0,
the frame of the controllers' tool/load data). At commanded joints its position is
``p = o_n + R_n c`` (the flange frame {n}'s origin and rotation), and its gravity torque about the
axis of joint i, per unit of gravity, is ``tau_i = m z_i . ((p - o_i) x g_hat)`` (kg m), with
``z_i, o_i`` the joint's axis and origin and ``g_hat`` the unit vector -z of the robot base
frame {0} (a floor-mounted robot, as :mod:`robocal.kinematics.joint_errors`' compliance term). The
joint turns ``dq_i = c_i tau_i`` further, ``c_i = k_i |g|`` (rad per kg m) with ``k_i`` the
joint's compliance (rad/(N m)): parameter ``payload{i}``.

Joint 1's axis is the base frame's z, vertical, for every arm robocal models: gravity has no
moment about it, so the term has the joints 2..n (``payload2..payloadn``).

Shared compliance: physically ``k_i`` is the same stiffness that bends joint i under the arm's own
weight (the compliance term's ``comp{i}_{j} = k_i m_j |g|``). The own-weight term identifies
only the products ``k_i m_j`` (the lumped masses ``m_j`` are unknown), so tying ``payload{i}`` to
them would need the masses and make the model nonlinear; ``payload{i}`` is therefore its own
linear parameter, determined by data measured at different payloads. Both together give the
lumped masses as ``comp{i}_{j} / payload{i}``.
"""

from __future__ import annotations

import re

import numpy as np

PATTERN = re.compile(r"^payload(\d+)$")
UNIT = "rad/(kg m)"
FIRST_JOINT = 2  # joint 1 is vertical: no gravity moment about it


def names(n: int) -> list[str]:
    """The parameter names of the payload term for an ``n``-joint robot."""
    return [f"payload{i}" for i in range(FIRST_JOINT, n + 1)]


def joint_of(name: str, n: int) -> int | None:
    """0-based joint of a payload parameter name for an ``n``-joint robot, or None."""
    m = PATTERN.match(name)
    return int(m[1]) - 1 if m and FIRST_JOINT <= int(m[1]) <= n else None


def moment_basis(frames: np.ndarray, payload: np.ndarray | None, joints: np.ndarray) -> np.ndarray:
    """``(N, k)`` kg m: the payload's gravity moment ``m z_i . ((p - o_i) x g_hat)`` about joint
    ``joints[k]`` (0-based) of each pose, from the world frames ``(N, n + 1, 4, 4)`` of
    :func:`robocal.kinematics.fk.chain_frames` at the commanded joints and ``payload (N, 4)``
    (kg, centre of mass x, y, z in m in the flange frame); zeros when ``payload`` is None (no
    payload)."""
    N = frames.shape[0]
    if payload is None:
        return np.zeros((N, len(joints)))
    payload = np.asarray(payload, float)
    flange = frames[:, -1]
    p = flange[:, :3, 3] + np.einsum("nij,nj->ni", flange[:, :3, :3], payload[:, 1:])  # (N, 3)
    g = -frames[:, 0, :3, 2]
    axes = frames[:, np.asarray(joints) + 1]  # (N, k, 4, 4): frame {i + 1} turns about joint i
    z = axes[..., :3, 2]  # (N, k, 3)
    arm = p[:, None, :] - axes[..., :3, 3]
    return payload[:, :1] * np.einsum("nkj,nkj->nk", z, np.cross(arm, g[:, None, :]))
