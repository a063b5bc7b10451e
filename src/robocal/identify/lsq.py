"""Method ``lsq`` (seed 000, steps 1-5): linearise, solve with the Moore-Penrose inverse,
update — with Levenberg-Marquardt damping so it converges from the nominal model.

Each iteration re-linearises at the current model (rotations of base and tool are composed
multiplicatively), so the iteration is Gauss-Newton on the parameter manifold; the damping
schedule and stopping rules are robocal's one damped least-squares loop
(:mod:`robocal.core.damped_least_squares`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from robocal.core.damped_least_squares import Status, minimize
from robocal.core.resources import few_threads
from robocal.identify.linalg import ScaledSVD
from robocal.identify.solvers import SolverResult, history_entry
from robocal.identify.space import ParameterSpace, State

STEP_TOL = 1e-13  # largest change of a unit-scaled column's contribution that still counts as a step
FTOL = 1e-10  # converged when the linear model predicts a decrease below this fraction of the cost


class GaussNewtonResult(NamedTuple):
    """The final state, how it stopped, accepted steps, history, the total displacement
    ``(space.size,)`` from the start (what the robust ridge regularises) and the problem's
    (unweighted) Jacobian ``(M, space.size)`` at the final state when the loop computed it there
    (None after stopping at the iteration limit), so a caller never builds it twice."""

    state: State
    status: Status
    nit: int
    history: list[dict]
    total: np.ndarray
    jacobian: np.ndarray | None


class _Calibration:
    """One calibration problem as the damped loop's single member (see DampedProblem). With a
    prior (``space.has_prior``), the residual vector is the data rows then one row per unknown
    with a prior (:meth:`ParameterSpace.prior_residuals`): the MAP estimate."""

    size = 1

    def __init__(self, problem, state: State, space: ParameterSpace, row_weights, ridge: float,
                 prior, ftol: float, jacobian=None, svd=None) -> None:
        self.problem, self.state, self.space = problem, state, space
        self.w = 1.0 if row_weights is None else np.sqrt(row_weights)
        self.ridge, self.ftol = ridge, ftol
        self.total = np.zeros(space.size) if prior is None else np.asarray(prior, float).copy()
        self.scale = None
        self.J_raw, self.J_state = jacobian, state  # the unweighted Jacobian and its state
        weight = space.prior_weight
        self.prior_rows = np.flatnonzero(weight > 0)
        self.prior_block = np.diag(weight)[self.prior_rows]  # (p, size): d(w value)/d(unknowns)
        # the caller's SVD is of the weighted data rows only: usable when there are no prior rows
        self.given_svd = svd if not self.prior_rows.size else None
        self.r = self._residuals(state)
        self.current = float(self.r @ self.r)  # + the ridge term once the scale is known

    def _residuals(self, state: State) -> np.ndarray:
        r = self.problem.residuals(state) * self.w
        if not self.prior_rows.size:
            return r
        return np.concatenate([r, self.space.prior_residuals(state)[self.prior_rows]])

    def _cost(self, r: np.ndarray, total: np.ndarray) -> float:
        c = float(r @ r)
        return c + self.ridge * float(np.sum((total * self.scale) ** 2)) if self.ridge else c

    def cost(self) -> np.ndarray:
        return np.array([self.current])

    def linearize(self, members) -> None:
        self.J = self.svd = None  # the previous linearisation's (M, k) arrays go before new ones come
        if self.J_raw is None or self.J_state is not self.state:
            self.J_raw = None
            self.J_raw, self.J_state = self.problem.jacobian(self.state, self.space), self.state
            self.given_svd = None
        unweighted = not np.ndim(self.w) and self.w == 1.0  # then no weighted copy of the (M, k) array
        self.J = self.J_raw if unweighted else self.J_raw * (self.w[:, None] if np.ndim(self.w) else self.w)
        if self.prior_rows.size:  # r = mean - value: the same sign convention as the data's rows
            self.J = np.vstack([self.J, self.prior_block])
        first = self.scale is None
        self.svd = ScaledSVD.of(self.J, self.scale) if self.given_svd is None else self.given_svd
        self.given_svd = None
        self.scale = self.svd.scale
        if first:  # the ridge term is measured in the scaled unknowns
            self.current = self.initial = self._cost(self.r, self.total)

    def propose(self, members, damping) -> np.ndarray:
        s0 = self.svd.s[0] ** 2 if self.svd.s.size else 1.0
        self.dx = self.svd.solve(self.r, damping=damping[0] * s0 + self.ridge,
                                 prior=self.total if self.ridge else None)
        return np.array([self.current - self._cost(self.r - self.J @ self.dx, self.total + self.dx)])

    def converged(self, members, predicted) -> np.ndarray:
        small_step = np.max(np.abs(self.dx * self.scale), initial=0.0) < STEP_TOL
        return np.array([predicted[0] <= self.ftol * max(self.current, 1e-300) or small_step])

    def trial_cost(self, members) -> np.ndarray:
        self.trial = self.space.apply(self.state, self.dx)
        self.r_trial = self._residuals(self.trial)
        self.c_trial = self._cost(self.r_trial, self.total + self.dx)
        return np.array([self.c_trial])

    def accept(self, members) -> None:
        if len(members):
            self.state, self.r, self.current = self.trial, self.r_trial, self.c_trial
            self.total = self.total + self.dx


@few_threads(lambda problem, *args, **kwargs: problem.sigma.size)
def gauss_newton(problem, state: State, space: ParameterSpace, *, row_weights=None,
                 max_iter: int = 50, ftol: float = FTOL, ridge: float = 0.0, prior=None,
                 progress=None, jacobian: np.ndarray | None = None,
                 svd: ScaledSVD | None = None) -> GaussNewtonResult:
    """Damped Gauss-Newton on ``space`` with fixed ``row_weights`` ``(M,)``.

    ``ridge`` (scaled units) with ``prior`` (the displacement accumulated so far, unscaled)
    regularises the total displacement (robust ridge). Converged when the linear model predicts
    a decrease below ``ftol`` times the cost, or the step is below rounding (exact data, where the
    cost itself is at rounding level); stalled when it predicts a real decrease that no damped
    step achieves. ``jacobian`` ``(M, space.size)``: the problem's Jacobian at ``state`` when the
    caller has it, and ``svd`` its :class:`ScaledSVD` after the row weights (own column scale).
    """
    lm = _Calibration(problem, state, space, row_weights, ridge, prior, ftol, jacobian, svd)
    n_items = problem.n_items
    steps = []

    def on_accept(members, nit) -> None:
        steps.append(history_entry(nit[0], lm.current, n_items))
        if progress is not None:
            progress(int(nit[0]), steps[-1]["rms"])

    out = minimize(lm, max_iter, on_accept)
    history = [history_entry(0, lm.initial, n_items), *steps]
    return GaussNewtonResult(lm.state, Status(out.status[0]), int(out.nit[0]), history, lm.total,
                             lm.J_raw if lm.J_state is lm.state else None)


def solve(problem, start: State, space: ParameterSpace, *, max_iter: int = 50, progress=None,
          **_) -> SolverResult:
    """Least squares from ``start`` over ``space``."""
    gn = gauss_newton(problem, start, space, max_iter=max_iter, progress=progress)
    message = {Status.CONVERGED: f"converged in {gn.nit} iterations",
               Status.MAX_ITERATIONS: f"not converged after {max_iter} iterations",
               Status.STALLED: f"stalled after {gn.nit} iterations: no damped step decreases the cost "
                               "although the linear model promises a decrease"}[gn.status]
    return SolverResult(state=gn.state, status=gn.status, message=message, nit=gn.nit,
                        history=gn.history)
