"""The physics of a simulated campaign's conditions: the payloads' deflection and the arm's
thermal expansion.

The truth of :func:`robocal.data.simulate.simulate_tracker` with ``payloads`` and
``temperatures``: the poses are measured in equal consecutive blocks, one per payload (in the
order given), the arm warming linearly from the lowest to the highest temperature within each
block; the payload's centre of mass is ``PAYLOAD_COM_M`` in the flange frame unless given.

The true robot deflects under the payload and expands with temperature. The measured points are
computed here from the physics, independently of the fitting code (:mod:`robocal.kinematics.load`,
:mod:`robocal.kinematics.thermal`): the gravity moment about each joint is minus the derivative of
the payload's potential energy, by central differences of the height of its centre of mass (the
plain FK of the true geometry), and the thermal expansion scales the true link lengths a, d
(the base height d_1 included) pose by pose before the FK. The written truth carries the same
effects as the ``payload{i}`` and ``thermal`` terms, so ``robot.fk`` of the truth with the rows'
conditions reproduces the points (the simulator's test checks that they agree).

True values: joint i (2..n) turns ``c_i`` rad per kg m of payload moment (``c_i = k_i |g|``),
uniform in ``PAYLOAD_DEFLECTION_MM`` of deflection at the reach for the heaviest payload held at
the reach, and the arm expands by ``THERMAL_PER_K`` per kelvin (steel) unless ``thermal_k`` gives
one k or a k per link group (:func:`check_thermal_k`; e.g. an aluminium forearm). The link groups
are those of :mod:`robocal.kinematics.thermal` (base column: links 1-2 of the arm; upper arm: 3;
forearm: 4..n-2; wrist: n-1, n), mapped to the links here on their own; the written truth carries a
per-group k as the shared ``thermal`` plus each group's deviation ``thermal_<group>``. T_ref is the
campaign's mean temperature. A truth that already carries these terms (``as_is``: the truth of an earlier
simulation measured again, e.g. at other conditions) keeps its values and T_ref.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robocal.core.errors import DataError
from robocal.kinematics.conditions import Conditions
from robocal.kinematics.fk import LinkArrays, chain_fk

PAYLOAD_COM_M = (0.0, 0.0, 0.25)  # default centre of mass in the flange frame, m
PAYLOAD_DEFLECTION_MM = (0.1, 0.4)  # true deflection (at the reach, heaviest payload at the reach) per joint
THERMAL_PER_K = 11.5e-6  # steel
THERMAL_K_MAX = 1e-4  # 1/K: the largest plausible |k| (structural metals 1e-5..3e-5; plastics ~1e-4)
SIM_GROUPS = ("base", "upper_arm", "forearm", "wrist")
HEIGHT_STEP_RAD = 1e-6  # central-difference step of the potential energy's derivative


def check(payloads, temperatures) -> tuple[np.ndarray | None, tuple[float, float] | None]:
    """Validated payloads ``(m,)`` kg and temperature range ``(lo, hi)`` deg C (None: not simulated)."""
    if payloads is not None:
        payloads = np.asarray(payloads, float).reshape(-1)
        if payloads.size == 0 or not np.isfinite(payloads).all() or (payloads < 0).any():
            raise DataError("payloads must be one or more masses >= 0 kg")
    if temperatures is not None:
        t = np.asarray(temperatures, float).reshape(-1)
        if t.size != 2 or not np.isfinite(t).all() or t[0] > t[1] or t[0] < -40 or t[1] > 120:
            raise DataError("temperatures must be a range LO:HI in deg C with -40 <= LO <= HI <= 120")
        temperatures = (float(t[0]), float(t[1]))
    return payloads, temperatures


def schedule(n_poses: int, payloads: np.ndarray | None, temperatures, com) -> tuple:
    """Per pose ``payload (n_poses, 4)`` (kg, m) and ``temperature (n_poses,)`` deg C (None where
    not simulated): one consecutive block per payload, warming within each block."""
    blocks = len(payloads) if payloads is not None else 1
    block = np.minimum(np.arange(n_poses) * blocks // n_poses, blocks - 1)
    payload = None
    if payloads is not None:
        com = np.asarray(PAYLOAD_COM_M if com is None else com, float).reshape(3)
        payload = np.c_[payloads[block], np.tile(com, (n_poses, 1))]
    temperature = None
    if temperatures is not None:
        lo, hi = temperatures
        starts = np.searchsorted(block, np.arange(blocks))
        size = np.diff(np.r_[starts, n_poses])
        within = np.arange(n_poses) - starts[block]
        temperature = lo + (hi - lo) * within / np.maximum(size[block] - 1, 1)
    return payload, temperature


def check_thermal_k(thermal_k) -> dict[str, float] | None:
    """Validated true expansion coefficients: None (steel everywhere), one k for the whole arm, or
    a mapping ``{group: k}`` (groups of :data:`SIM_GROUPS`; ``"all"`` for the groups not named,
    default steel), 1/K with ``|k| <=`` :data:`THERMAL_K_MAX`. Returns ``{group: k}`` for every
    group, or ``{"all": k}`` for one k, or None."""
    if thermal_k is None:
        return None
    given = dict(thermal_k) if isinstance(thermal_k, dict) else {"all": thermal_k}
    bad = sorted(set(given) - {"all", *SIM_GROUPS})
    if bad:
        raise DataError(f"unknown link group(s) {bad} for the thermal expansion; use {', '.join(SIM_GROUPS)}")
    out = {}
    for g, k in given.items():
        try:
            k = float(k)
        except (TypeError, ValueError):
            raise DataError(f"a thermal expansion coefficient is a number per kelvin, got {k!r}") from None
        if not np.isfinite(k) or abs(k) > THERMAL_K_MAX:
            raise DataError(f"thermal expansion coefficient {g} = {k:g} per K is not plausible "
                            f"(|k| <= {THERMAL_K_MAX:g}; steel 11.5e-6, aluminium 23e-6)")
        out[g] = k
    if set(out) == {"all"}:
        return out
    default = out.pop("all", THERMAL_PER_K)
    return {g: out.get(g, default) for g in SIM_GROUPS}


def true_terms(robot, payloads: np.ndarray | None, temperatures, reach: float,
               rng: np.random.Generator, thermal_k: dict[str, float] | None = None) -> dict[str, float]:
    """The true payload{i} (rad per kg m) and thermal (1/K) values, drawn as the module says
    (``thermal_k``: :func:`check_thermal_k`'s), or ``robot``'s own where it declares them
    (``as_is``: a truth measured again)."""
    errors = robot.joint_errors
    own = {} if errors is None else {nm: float(v) for nm, v in zip(errors.names, errors.values, strict=True)
                                     if nm.startswith("thermal") or nm.startswith("payload")}
    if own:
        if thermal_k is not None and any(nm.startswith("thermal") for nm in own):
            raise DataError("the model measured as it is carries its own thermal expansion: a true "
                            "thermal k cannot be given too")
        return own
    values = {}
    if payloads is not None and payloads.max() > 0:
        moment = payloads.max() * reach  # kg m: the heaviest payload held at the reach
        for i in range(2, robot.n_joints + 1):
            values[f"payload{i}"] = rng.uniform(*PAYLOAD_DEFLECTION_MM) * 1e-3 / reach / moment
    if temperatures is not None:
        if thermal_k is None or set(thermal_k) == {"all"}:
            values["thermal"] = THERMAL_PER_K if thermal_k is None else thermal_k["all"]
        else:  # written as the shared k (the base column's) and each group's deviation from it
            values["thermal"] = thermal_k["base"]
            values.update({f"thermal_{g}": k - thermal_k["base"] for g, k in thermal_k.items()})
    return values


def link_expansion(coefficients: dict[str, float], prismatic: np.ndarray) -> np.ndarray:
    """``(n,)`` 1/K: each link's true expansion coefficient, the shared ``thermal`` plus its group's
    ``thermal_<group>``: the arm's links (after leading prismatic joints) 1-2 base, 3 upper arm,
    4..m-2 forearm, m-1..m wrist, on an arm of m >= 6 revolute joints; other links the shared k."""
    n = len(prismatic)
    k = np.full(n, coefficients.get("thermal", 0.0))
    lead = 0
    while lead < n and prismatic[lead]:
        lead += 1
    m = n - lead
    if m < 6 or any(prismatic[lead:]):
        return k
    for link in range(1, m + 1):
        group = "base" if link <= 2 else "upper_arm" if link == 3 else "forearm" if link <= m - 2 else "wrist"
        k[lead + link - 1] += coefficients.get(f"thermal_{group}", 0.0)
    return k


def gravity_moments(plain, q: np.ndarray, payload: np.ndarray) -> np.ndarray:
    """``(N, n)`` kg m: the payload's gravity moment about each joint per unit g, ``-m dh/dq_i``
    with ``h`` the height (robot base frame z) of its centre of mass, by central differences of
    the FK of ``plain`` (a robot without joint errors; its base and tool are ignored)."""
    N, n = q.shape
    moments = np.empty((N, n))
    links = plain.links
    for i in range(n):
        step = np.zeros(n)
        step[i] = HEIGHT_STEP_RAD
        h = [_com_height(links, q + s * step, payload[:, 1:]) for s in (1.0, -1.0)]
        moments[:, i] = -payload[:, 0] * (h[0] - h[1]) / (2 * HEIGHT_STEP_RAD)
    return moments


def _com_height(links: LinkArrays, q: np.ndarray, com: np.ndarray) -> np.ndarray:
    tool = np.broadcast_to(np.eye(4), (len(q), 4, 4)).copy()
    tool[:, :3, 3] = com
    return chain_fk(links, np.eye(4), tool, q)[:, 2, 3]


def measured_poses(true, q: np.ndarray, smr: np.ndarray, conditions: Conditions,
                   coefficients: dict[str, float], reference: float) -> np.ndarray:
    """TCP poses ``(N, 4, 4)`` of the true robot ``true`` (its own joint errors, without the
    condition terms) at commanded ``q (N, n)`` reached at ``conditions`` (approach directions and
    moves) carrying their payload ``(N, 4)`` at their temperature ``(N,)`` (either None), with the
    true ``coefficients`` (:func:`true_terms`)."""
    n = q.shape[1]
    payload, temperature = conditions.payload, conditions.temperature
    reached = true.reached_joints(q, conditions.motion)
    if payload is not None and payload[:, 0].any():
        plain = replace(true, joint_errors=None)
        c = np.array([coefficients.get(f"payload{i + 1}", 0.0) for i in range(n)])
        reached = reached + c * gravity_moments(plain, q, payload)
    links = true.links
    if temperature is not None:
        s = 1.0 + np.outer(np.asarray(temperature) - reference, link_expansion(coefficients, true.prismatic))
        links = LinkArrays(links.alpha, links.a * s, links.beta, links.theta, links.d * s)
    return chain_fk(links, true.base, true.tools_for(smr), reached, prismatic=true.prismatic)
