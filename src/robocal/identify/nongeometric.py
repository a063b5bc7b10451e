"""Non-geometric terms identified jointly with the geometric parameters (methods lsq, robust).

Terms (see :mod:`robocal.kinematics.joint_errors` for the models): ``compliance`` (joint
compliance under the gravity torque of lumped link masses), ``gear`` (first and second
harmonics of each joint angle) and ``backlash`` (lost motion by the direction each joint
approached the pose from, taken from the measurement order), ``travel`` (an error proportional
to each joint's last move) and ``cyclic`` (a transmission's periodic error at frequencies found
from the data by :mod:`robocal.identify.frequency_search`; here only as explicit parameter names
such as ``cyc4_50_s``, which ``nongeometric`` also accepts). Their parameters join the problem
as extra unknowns after the observation's nuisance parameters; their Jacobian columns are
analytic::

    d(TCP)/d(p) = d(TCP)/d(theta_i) * d(dq_i)/d(p)     (tau_ij(q), sin/cos, or the direction)

with d(TCP)/d(theta_i) the identification Jacobian at the joints the robot reaches. The small
dependence of tau_ij on the link parameters is left out of the link columns (second order).
Which parameters are kept: a third identifiability stage after the geometric one — the part of
each column the kept geometric columns explain is removed, then pivoted QR — so of a
confounded pair the geometric parameter is kept (e.g. theta_i rather than gear_i c1 on a joint
that hardly moves). A joint-error parameter is kept only when at least 1/sqrt(NG_MAX_VIF) of its
(unit-scaled) column is independent of the geometry and of the joint-error columns kept before it,
i.e. its variance inflation factor stays below NG_MAX_VIF: a nearly confounded term (e.g. the
harmonics of a joint that moves over a narrow range, pinned down by a few extreme poses) would
otherwise fit those few poses and predict new ones badly. The learned residual
(:mod:`robocal.identify.residual`) is fitted on the calibrated model's remaining errors, separately.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from robocal.errors import IdentificationError
from robocal.identify.identifiability import DEFAULT_RTOL, _pivoted_rank
from robocal.kinematics.joint_errors import (
    TERMS,
    JointErrorModel,
    is_parameter_name,
    joint_error_basis,
    term_names,
    term_of,
)

ALL_TERMS = TERMS
NG_MAX_VIF = 1000.0  # largest variance inflation factor of a kept joint-error parameter
NG_RTOL = float(1.0 / np.sqrt(NG_MAX_VIF))


def parse_terms(spec) -> list[str]:
    """``'compliance,gear'`` / a list -> validated term names and explicit joint-error parameter
    names (e.g. ``cyc4_50_s``), order kept, no repeats."""
    items = spec.replace(",", " ").split() if isinstance(spec, str) else list(spec or [])
    bad = [t for t in items if t not in ALL_TERMS and not is_parameter_name(str(t))]
    if bad:
        raise IdentificationError(f"unknown non-geometric term(s) {bad}; choose from "
                                  f"{', '.join(ALL_TERMS)} or auto (comma separated), or name "
                                  "joint-error parameters such as backlash2 or cyc4_50_s")
    return list(dict.fromkeys(items))


def candidate_names(n: int, items: Sequence[str]) -> list[str]:
    """The parameter names of terms and explicit names ``items`` for an ``n``-joint robot."""
    names = [nm for t in items for nm in (term_names(n, t) if t in TERMS else [t])]
    return list(dict.fromkeys(names))


class NonGeometricObservation:
    """Wraps an observation: applies ``q + dq(q)`` and adds the joint-error unknowns."""

    def __init__(self, inner, names: Sequence[str]) -> None:
        self.inner = inner
        self.names = list(names)
        self.q0 = inner.q
        self.m0 = len(inner.nuisance_names)
        self.nuisance_names = list(inner.nuisance_names) + self.names

    def __getattr__(self, attr):  # kind, rows_per_item, measured, n_items, residual_scale ...
        if attr == "inner":
            raise AttributeError(attr)
        return getattr(self.inner, attr)

    def _at(self, robot, nuisance):
        robot = robot if robot.joint_errors is None else replace(robot, joint_errors=None)
        nuisance = np.asarray(nuisance, dtype=float)
        B, joint = joint_error_basis(robot, self.q0, self.names, self.inner.approach, self.inner.travel)
        dq = np.zeros_like(self.q0)
        np.add.at(dq.T, joint, (B * nuisance[self.m0:]).T)
        obs = copy.copy(self.inner)
        obs.q = self.q0 + dq
        return obs, robot, nuisance[: self.m0], B, joint

    def nuisance_start(self, robot) -> np.ndarray:
        return np.concatenate([self.inner.nuisance_start(robot), np.zeros(len(self.names))])

    def residuals(self, robot, nuisance) -> np.ndarray:
        obs, robot, nu, *_ = self._at(robot, nuisance)
        return obs.residuals(robot, nu)

    def jacobian(self, robot, names, nuisance) -> np.ndarray:
        obs, robot, nu, B, joint = self._at(robot, nuisance)
        n, k = robot.n_joints, len(names)
        J = obs.jacobian(robot, list(names) + [f"theta{i + 1}" for i in range(n)], nu)  # one pass
        Jq = J[:, k : k + n]
        Bq = np.repeat(B, self.rows_per_item, axis=0)
        return np.hstack([J[:, :k], J[:, k + n :], Jq[:, joint] * Bq])

    def residuals_batch(self, robot, names, X, nuisance=None) -> np.ndarray:
        obs, robot, nu, *_ = self._at(robot, nuisance)
        return obs.residuals_batch(robot, names, X, nu)

    def modelled_points(self, robot, nuisance) -> np.ndarray:
        obs, robot, nu, *_ = self._at(robot, nuisance)
        return obs.modelled_points(robot, nu)

    def position_errors(self, robot, nuisance) -> np.ndarray:
        obs, robot, nu, *_ = self._at(robot, nuisance)
        return obs.position_errors(robot, nu)

    def calibrated_robot(self, state):
        """The state's robot carrying the identified joint-error model (what fk applies)."""
        values = np.asarray(state.nuisance, float)[self.m0:]
        return replace(state.robot, joint_errors=JointErrorModel(tuple(self.names), values))


def select_parameters(problem, state, names: Sequence[str], candidates: Sequence[str],
                      rtol: float = DEFAULT_RTOL) -> tuple[list[str], list[str]]:
    """(kept, dropped) joint-error candidates: third identifiability stage after ``names``."""
    trial = NonGeometricObservation(problem.observation, candidates)
    nu = np.concatenate([state.nuisance, np.zeros(len(candidates))])
    J = trial.jacobian(state.robot, names, nu) / problem.sigma[:, None]
    kept_idx = independent_columns(J, J.shape[1] - len(candidates), rtol)
    kept = [candidates[i] for i in kept_idx]
    return kept, [c for c in candidates if c not in kept]


def independent_columns(J: np.ndarray, k0: int, rtol: float = DEFAULT_RTOL) -> np.ndarray:
    """Sorted indices (0-based among columns ``k0:``) of the joint-error columns of ``J (M, k)``
    kept after the geometric columns ``J[:, :k0]`` (the third identifiability stage)."""
    norms = np.linalg.norm(J, axis=0)
    Js = J / np.where(norms > 1e-300, norms, 1.0)
    Js[:, norms <= 1e-9 * norms.max(initial=0.0)] = 0.0  # no effect (e.g. torque about a vertical axis)
    _, Qg = _pivoted_rank(Js[:, :k0], rtol)
    ng = Js[:, k0:]
    ng = ng - Qg @ (Qg.T @ ng)
    kept_idx, _ = _pivoted_rank(ng, max(rtol, NG_RTOL))
    return np.sort(kept_idx)


def attach(problem, state, names: Sequence[str], terms: Sequence[str], rtol: float = DEFAULT_RTOL):
    """Add the joint-error terms to ``problem`` (in place) after the geometric selection.

    Returns ``(state0, info)`` with the new start state and ``{"terms", "kept", "dropped"}``."""
    candidates = candidate_names(state.robot.n_joints, terms)
    if not candidates:
        raise IdentificationError(f"the non-geometric terms {list(terms)} have no parameters to add")
    kept, dropped = select_parameters(problem, state, names, candidates, rtol)
    problem.observation = NonGeometricObservation(problem.observation, kept)
    asked = {t if t in TERMS else term_of(t) for t in terms}
    return problem.start(state.robot), {"terms": [t for t in TERMS if t in asked], "kept": kept,
                                        "dropped": dropped}
