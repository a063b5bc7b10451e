"""Non-geometric terms identified jointly with the geometric parameters (methods lsq, robust).

Terms (see :mod:`robocal.kinematics.joint_errors` for the models): ``compliance`` (joint
compliance under the gravity torque of lumped link masses), ``gear`` (first and second
harmonics of each joint angle) and ``backlash`` (lost motion by the direction each joint
approached the pose from, taken from the measurement order). Their parameters join the problem
as extra unknowns after the observation's nuisance parameters; their Jacobian columns are
analytic::

    d(TCP)/d(p) = d(TCP)/d(theta_i) * d(dq_i)/d(p)     (tau_ij(q), sin/cos, or the direction)

with d(TCP)/d(theta_i) the identification Jacobian at the joints the robot reaches. The small
dependence of tau_ij on the link parameters is left out of the link columns (second order).
Which parameters are kept: a third identifiability stage after the geometric one — the part of
each column the kept geometric columns explain is removed, then pivoted QR — so of a
confounded pair the geometric parameter is kept (e.g. theta_i rather than gear_i c1 on a joint
that hardly moves). The learned residual (:mod:`robocal.identify.residual`) is fitted on
the calibrated model's remaining errors, separately.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from robocal.errors import IdentificationError
from robocal.identify.identifiability import DEFAULT_RTOL, _pivoted_rank
from robocal.kinematics.joint_errors import TERMS, JointErrorModel, joint_error_basis, term_names

ALL_TERMS = TERMS


def parse_terms(spec) -> list[str]:
    """``'compliance,gear'`` / a list -> validated term names (order kept, no repeats)."""
    items = spec.replace(",", " ").split() if isinstance(spec, str) else list(spec or [])
    bad = [t for t in items if t not in ALL_TERMS]
    if bad:
        raise IdentificationError(f"unknown non-geometric term(s) {bad}; choose from "
                                  f"{', '.join(ALL_TERMS)} (comma separated)")
    return list(dict.fromkeys(items))


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
        B, joint = joint_error_basis(robot, self.q0, self.names, self.inner.approach)
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
        J = obs.jacobian(robot, names, nu)
        n = robot.n_joints
        Jq = obs.jacobian(robot, [f"theta{i + 1}" for i in range(n)], nu)[:, :n]
        Bq = np.repeat(B, self.rows_per_item, axis=0)
        return np.hstack([J, Jq[:, joint] * Bq])

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
    k0 = J.shape[1] - len(candidates)
    norms = np.linalg.norm(J, axis=0)
    Js = J / np.where(norms > 1e-300, norms, 1.0)
    Js[:, norms <= 1e-9 * norms.max(initial=0.0)] = 0.0  # no effect (e.g. torque about a vertical axis)
    _, Qg = _pivoted_rank(Js[:, :k0], rtol)
    ng = Js[:, k0:]
    ng = ng - Qg @ (Qg.T @ ng)
    kept_idx, _ = _pivoted_rank(ng, rtol)
    kept = [candidates[i] for i in sorted(kept_idx.tolist())]
    return kept, [c for c in candidates if c not in kept]


def attach(problem, state, names: Sequence[str], terms: Sequence[str], rtol: float = DEFAULT_RTOL):
    """Add the joint-error terms to ``problem`` (in place) after the geometric selection.

    Returns ``(state0, info)`` with the new start state and ``{"terms", "kept", "dropped"}``."""
    n = state.robot.n_joints
    candidates = [nm for t in terms if t in TERMS for nm in term_names(n, t)]
    kept, dropped = select_parameters(problem, state, names, candidates, rtol)
    problem.observation = NonGeometricObservation(problem.observation, kept)
    return problem.start(state.robot), {"terms": list(terms), "kept": kept, "dropped": dropped}
