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

The load's lever (``payload{i}_x``, ``_y``, ``_z``): the centre of mass the rows record (or the
flange's origin when they record only the mass) is rarely the true one to the centimetre, and at
a heavy arm's compliance a few centimetres of lever are tenths of a millimetre at the tool. The true
centre of mass ``c + delta`` adds ``c_i m z_i . ((R_n delta) x g_hat) = c_i m delta . (R_n^T (g_hat x
z_i))`` to joint i's turn: linear in the products ``c_i delta`` (rad/kg: the joint's compliance
times the centre of mass's error along the flange's x, y, z axes), one per joint and flange axis,
the unknown shared ``delta`` relaxed to a product per joint so the model stays linear. Joint n
turns about the flange's z axis, so an error along it has no moment there: ``payload{n}_z`` does
not exist. The term carries the corrections of the joints before the wrist (:data:`WRIST_JOINTS`),
whose lever to the load changes with the arm's configuration; :func:`lever_correction` recovers
``delta`` from their fitted values. On a spherical wrist the load's lever about joints 4..6 is
fixed in the flange frame, so there a compliance and its lever corrections are one product (the
identifiability analysis sets a lever correction named explicitly aside). The corrections belong to
the load the calibration measured: a load whose recorded centre of mass is off by another error needs
rows of its own. An independent truth (``benchmarks/payload_truth.py``: joints yielding 1-4 mm at the
reach, the recorded centre of mass 10 cm off the true one) reached 1.45-1.63x the noise floor held
out without the corrections (``auto`` added the payload-independent compliance term: 1.33-1.45x)
and 1.04x with them (``benchmarks/bench_payload_thermal.py``).
"""

from __future__ import annotations

import re

import numpy as np

PATTERN = re.compile(r"^payload(\d+)(?:_([xyz]))?$")
UNIT = "rad/(kg m)"
LEVER_UNIT = "rad/kg"  # payload{i}_x..z: the compliance times the centre of mass's error (m)
AXES = "xyz"  # the flange frame's axes of the lever correction
# The last joints (the wrist) get no lever corrections by default: they are close to the load, so
# their share of the moment's error moves the tool by c_i m delta times the wrist-to-tool distance
# (hundredths of a millimetre on a KR 210 with the load 10 cm off), and on a spherical wrist their
# correction and compliance are one product; fitted, they only add variance where the model is used
# with another load (bench_payload_thermal's KRL program, 120 kg at 300 mm: 0.0294 mm model error
# with them, 0.0248 without; the independent truth's held-out ratio 1.04 either way).
WRIST_JOINTS = 3
FIRST_JOINT = 2  # joint 1 is vertical: no gravity moment about it


def names(n: int) -> list[str]:
    """The parameter names of the payload term for an ``n``-joint robot: each joint's compliance
    ``payload{i}``, then the lever corrections ``payload{i}_x.._z`` of the joints before the wrist
    (:data:`WRIST_JOINTS`; a wrist joint's may be named explicitly)."""
    levers = [f"payload{i}_{a}" for i in range(FIRST_JOINT, n - WRIST_JOINTS + 1) for a in AXES]
    return [f"payload{i}" for i in range(FIRST_JOINT, n + 1)] + levers


def joint_of(name: str, n: int) -> int | None:
    """0-based joint of a payload parameter name for an ``n``-joint robot, or None."""
    m = PATTERN.match(name)
    if not m or not FIRST_JOINT <= int(m[1]) <= n or (m[2] == "z" and int(m[1]) == n):
        return None
    return int(m[1]) - 1


def axis_of(name: str) -> int | None:
    """The flange axis (0, 1, 2 for x, y, z) of a lever-correction name, None for a compliance."""
    m = PATTERN.match(name)
    return None if m is None or m[2] is None else AXES.index(m[2])


def is_lever(name: str) -> bool:
    """Whether ``name`` is a lever correction ``payload{i}_x|y|z``."""
    return axis_of(name) is not None


def unit_of(name: str) -> str:
    """SI unit of a payload parameter."""
    return LEVER_UNIT if is_lever(name) else UNIT


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


def lever_basis(frames: np.ndarray, payload: np.ndarray | None, joints: np.ndarray,
                axes: np.ndarray) -> np.ndarray:
    """``(N, k)`` kg: the columns of the lever corrections, ``m [R_n^T (g_hat x z_i)]_a`` for joint
    ``joints[k]`` (0-based) and flange axis ``axes[k]`` (0, 1, 2), from the world frames ``(N, n +
    1, 4, 4)`` at the commanded joints and ``payload (N, 4)`` (zeros when None): the change of the
    moment :func:`moment_basis` per metre of the centre of mass moved along that flange axis."""
    N = frames.shape[0]
    if payload is None:
        return np.zeros((N, len(joints)))
    payload = np.asarray(payload, float)
    g = -frames[:, 0, :3, 2]
    z = frames[:, np.asarray(joints) + 1][..., :3, 2]  # (N, k, 3)
    lever = np.einsum("nja,nkj->nka", frames[:, -1, :3, :3], np.cross(g[:, None, :], z))  # R_n^T (g x z)
    return payload[:, :1] * np.take_along_axis(lever, np.asarray(axes)[None, :, None], axis=2)[..., 0]


def lever_correction(values: dict[str, float], joints) -> np.ndarray | None:
    """The centre of mass's error ``delta (3,)`` m in the flange frame implied by fitted values
    ``{name: value}`` of the payload term, from ``joints`` (1-based): per flange axis the
    least-squares ratio of ``payload{i}_a`` to ``payload{i}`` over them. Use joints whose lever to
    the load changes with the arm's configuration (an arm's shoulder and elbow): on a wrist joint
    whose axis passes through a point fixed to the flange, the compliance and the lever are one
    product (the model predicts the load it was calibrated with, the split is not determined).
    None when no joint has both values or every compliance is 0."""
    out = np.full(3, np.nan)
    for a, axis in enumerate(AXES):
        pairs = np.array([(values[f"payload{i}"], values[f"payload{i}_{axis}"]) for i in joints
                          if f"payload{i}" in values and f"payload{i}_{axis}" in values]).reshape(-1, 2)
        c = pairs[:, 0]
        if float(c @ c) > 0:
            out[a] = float(c @ pairs[:, 1]) / float(c @ c)
    return None if np.isnan(out).all() else out
