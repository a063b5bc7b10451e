"""Thermal expansion of the arm: the link lengths grow with the arm's temperature.

The link lengths ``a_i, d_i`` of the arm (the base height ``d_1`` included) are scaled by
``s_i = 1 + k_i (T - T_ref)``: ``T`` (deg C) the arm's temperature at the pose, ``T_ref`` the
reference, the calibration data's mean temperature (saved with the model), ``k_i`` (1/K) the
expansion coefficient of link i (about 11.5e-6 for steel, 23e-6 for aluminium). The tracker-to-base
frame, the tool and the SMRs are not scaled (the tracker frame is fitted to each data set; tool and
SMR are short). Joint angles and twists do not change.

Parameters: ``thermal`` (1/K), the coefficient shared by every link, and, per link group, the
group's deviation from it, ``thermal_<group>`` (term ``thermal_groups``): ``k_i = thermal +
thermal_<group of link i>``. A group whose deviation the data do not determine is held at zero,
so it falls back to the shared k. The groups of an arm of six or more revolute joints (after any
leading prismatic joints, a track, whose links take the shared k), numbered by the links of the
modified DH chain (link i carries ``a_{i-1}`` and ``d_i``) counted from the arm's first joint:

=========== ===================== =====================================================
group       links                 a common 6-axis arm (KUKA KR 210 R2700)
=========== ===================== =====================================================
base        1, 2                  the base column: base height d1, shoulder offset a1
upper_arm   3                     the upper arm a2 (shoulder to elbow)
forearm     4 .. n-2              the forearm: elbow offset a3 and length d4
wrist       n-1, n                the wrist and flange: d5, d6
=========== ===================== =====================================================

An arm with fewer than six arm joints has no groups (their deviations have no effect).

The TCP moves by ``dp/dk = (T - T_ref) sum_i (a_i dp/da_i + d_i dp/dd_i)`` over the links the
parameter scales: a translation, pose by pose, from the link-length columns of the geometric
Jacobian. Without a temperature the model predicts the arm at ``T_ref``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robocal.kinematics.fk import LinkArrays

NAME = "thermal"
GROUPS_TERM = "thermal_groups"
GROUPS = ("base", "upper_arm", "forearm", "wrist")
GROUP_NAMES = tuple(f"{NAME}_{g}" for g in GROUPS)
GROUP_LABELS = {"base": "base column", "upper_arm": "upper arm", "forearm": "forearm",
                "wrist": "wrist/flange"}
MIN_ARM_JOINTS = 6  # revolute arm joints the grouping needs (base 2, upper arm 1, forearm >= 1, wrist 2)
UNIT = "1/K"
DEFAULT_REFERENCE_C = 20.0  # T_ref of a model whose calibration recorded no temperature
# a per-group model is tried only over at least this temperature span: at 5 K a 1 m link whose k
# differs by the steel-aluminium 11.5e-6/K moves 0.06 mm, about a laser tracker's noise
MIN_GROUP_SPAN_K = 5.0


def is_name(name: str) -> bool:
    """Whether ``name`` is a thermal parameter (the shared k or a group's deviation)."""
    return name == NAME or name in GROUP_NAMES


def link_groups(prismatic: np.ndarray) -> np.ndarray:
    """``(n,)`` the group index (into :data:`GROUPS`) of each link of a chain with joint kinds
    ``prismatic (n,)`` bool, -1 for a link in no group (a track's; every link of a short arm)."""
    prismatic = np.asarray(prismatic, bool)
    n = prismatic.size
    lead = int(np.argmin(prismatic)) if not prismatic.all() else n  # leading prismatic joints
    out = np.full(n, -1)
    m = n - lead
    if m < MIN_ARM_JOINTS or prismatic[lead:].any():
        return out
    i = np.arange(1, m + 1)  # arm link numbers
    out[lead:] = np.select([i <= 2, i == 3, i <= m - 2], [0, 1, 2], 3)
    return out


def link_mask(name: str, prismatic: np.ndarray) -> np.ndarray:
    """``(n,)`` bool: the links thermal parameter ``name`` scales."""
    if name == NAME:
        return np.ones(len(prismatic), bool)
    return link_groups(prismatic) == GROUP_NAMES.index(name)


def link_coefficients(names: Sequence[str], values: np.ndarray, prismatic: np.ndarray) -> np.ndarray | None:
    """``(..., n)`` 1/K: each link's expansion coefficient from the joint-error parameters ``names``
    with ``values (..., m)`` (one set or a batch); None when none of them is thermal."""
    cols = [(p, nm) for p, nm in enumerate(names) if is_name(nm)]
    if not cols:
        return None
    values = np.asarray(values, float)
    out = np.zeros(values.shape[:-1] + (len(prismatic),))
    for p, nm in cols:
        out = out + values[..., p, None] * link_mask(nm, prismatic)
    return out


def scale(k: np.ndarray | None, temperature: np.ndarray | None, reference: float) -> np.ndarray | None:
    """``(..., N, n)`` length scale ``1 + k_i (T - T_ref)`` for per-link coefficients ``k (..., n)``
    (:func:`link_coefficients`) and ``temperature (N,)`` deg C; None without a temperature (the arm
    at T_ref) or without coefficients."""
    if temperature is None or k is None:
        return None
    dt = np.asarray(temperature, float) - reference
    return 1.0 + np.asarray(k, float)[..., None, :] * dt[:, None]


def scaled_links(links: LinkArrays, s: np.ndarray | None) -> LinkArrays:
    """``links`` with ``a, d`` multiplied by the per-pose, per-link scale ``s (..., N, n)``;
    ``links`` unchanged when ``s`` is None."""
    if s is None:
        return links
    return LinkArrays(links.alpha, np.asarray(links.a) * s, links.beta, links.theta, np.asarray(links.d) * s)


def translation_axis(u: np.ndarray, links: LinkArrays, temperature: np.ndarray | None,
                     reference: float, mask: np.ndarray | None = None) -> np.ndarray:
    """``(3, N)`` m per (1/K): the TCP translation per unit of a coefficient scaling the links
    ``mask (n,)`` bool (None: all), from the motion axes ``u (3, P, N)`` of
    :func:`robocal.kinematics.jacobian.motion_axes` (the a_i axes at 5i + 1, the d_i axes at
    5i + 4) and the unscaled ``links`` ``(n,)``."""
    n = len(links.a)
    if temperature is None:
        return np.zeros((3, u.shape[-1]))
    L = 5 * n
    w = np.ones(n) if mask is None else np.asarray(mask, float)
    a, d = (np.asarray(v, float)[:, None] * w[:, None] for v in (links.a, links.d))
    growth = u[:, 1:L:5] * a + u[:, 4:L:5] * d
    return growth.sum(axis=1) * (np.asarray(temperature, float) - reference)


def reference_of(temperatures: list[np.ndarray | None]) -> float:
    """T_ref (deg C): the mean of the recorded temperatures of the data sets, or
    :data:`DEFAULT_REFERENCE_C` when none recorded one."""
    t = [np.asarray(x, float) for x in temperatures if x is not None]
    return float(np.concatenate(t).mean()) if t else DEFAULT_REFERENCE_C


def group_coefficients(values: dict[str, float]) -> dict[str, float]:
    """Each group's k (1/K), ``thermal + thermal_<group>``, from the parameter ``values`` (a group
    without its own deviation: the shared k)."""
    shared = float(values.get(NAME, 0.0))
    return {g: shared + float(values.get(nm, 0.0)) for g, nm in zip(GROUPS, GROUP_NAMES, strict=True)}


def groups_of(robot, estimated: Sequence[str]) -> list[dict] | None:
    """:func:`group_sources` of ``robot``'s error model with the parameters ``estimated`` (a
    calibration's unknowns); None when the model has no per-group deviations."""
    errors = robot.joint_errors
    if errors is None or not any(nm in GROUP_NAMES for nm in errors.names):
        return None
    values = dict(zip(errors.names, errors.values.tolist(), strict=True))
    return group_sources(values, set(estimated), robot.prismatic)


def group_sources(values: dict[str, float], estimated: set[str], prismatic: np.ndarray) -> list[dict]:
    """Per group of the arm's links: its k (1/K) and where it comes from: ``own`` (its deviation
    estimated from the data), ``shared`` (the shared k, estimated; its deviation not determined or
    not modelled) or ``prior`` (neither estimated: held at the prior mean). Empty without groups."""
    present = set(link_groups(prismatic).tolist())
    k = group_coefficients(values)
    out = []
    for j, (g, nm) in enumerate(zip(GROUPS, GROUP_NAMES, strict=True)):
        if j not in present:
            continue
        source = "own" if nm in estimated else "shared" if NAME in estimated else "prior"
        out.append({"group": g, "k_per_K": k[g], "source": source})
    return out
