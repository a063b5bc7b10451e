"""Method ``lsq`` (seed 000, steps 1-5): linearise, solve with the Moore-Penrose inverse,
update — with Levenberg-Marquardt damping so it converges from the nominal model.

Each iteration re-linearises at the current model (rotations of base and tool are composed
multiplicatively), so the iteration is Gauss-Newton on the parameter manifold.
"""

from __future__ import annotations

import numpy as np

from robocal.identify.linalg import ScaledSVD
from robocal.identify.solvers import SolverOutput

STEP_TOL = 1e-13  # largest change of a unit-scaled column's contribution that still counts as a step


def gauss_newton(problem, state, names, *, row_weights=None, max_iter: int = 50,
                 ftol: float = 1e-10, damping: float = 1e-6, ridge: float = 0.0,
                 prior=None, progress=None):
    """Damped Gauss-Newton on ``names`` + nuisance with fixed ``row_weights`` ``(M,)``.

    ``ridge`` (scaled units) with ``prior`` (the displacement accumulated so far, unscaled)
    regularises the total displacement (robust ridge). Converged when the linear model predicts
    a decrease below ``ftol`` times the cost, or the step is below rounding (exact data, where the
    cost itself is at rounding level); no trial evaluation is spent on it. Stalled (not
    converged) when it predicts a real decrease that no damped step achieves. Returns
    ``(state, converged, iterations, history, total_displacement)``.
    """
    w = np.ones_like(problem.residuals(state)) if row_weights is None else np.sqrt(row_weights)
    k = len(names) + len(problem.nuisance_names)
    total = np.zeros(k) if prior is None else np.asarray(prior, float).copy()

    def cost_of(r, tot):
        c = float(r @ r)
        return c + ridge * float(np.sum((tot * scale) ** 2)) if ridge else c

    J = problem.jacobian(state, names) * w[:, None]
    svd = ScaledSVD.of(J)
    scale = svd.scale
    r = problem.residuals(state) * w
    cost = cost_of(r, total)
    history = [{"iteration": 0, "cost": cost}]
    lam = damping
    converged = False
    for it in range(1, max_iter + 1):
        s0 = svd.s[0] ** 2 if svd.s.size else 1.0
        first_prediction = None
        while True:
            dx = svd.solve(r, damping=lam * s0 + ridge, prior=total if ridge else None)
            predicted = cost - cost_of(r - J @ dx, total + dx)
            first_prediction = predicted if first_prediction is None else first_prediction
            if predicted <= ftol * max(cost, 1e-300) or np.max(np.abs(dx * scale), initial=0.0) < STEP_TOL:
                converged = True  # nothing left to gain, or (exact data) a step below rounding
                break
            trial = problem.step(state, names, dx)
            r_new = problem.residuals(trial) * w
            cost_new = cost_of(r_new, total + dx)
            if cost_new < cost or lam > 1e8:
                break
            lam *= 10.0
        if converged:
            break
        if cost_new >= cost:
            # no damped step decreases the cost: at the minimum to rounding if the linear model
            # promised little, else stalled (reported as not converged)
            converged = first_prediction <= 1e-6 * cost
            break
        state, r, cost, total = trial, r_new, cost_new, total + dx
        lam = max(lam / 10.0, 1e-12)
        history.append({"iteration": it, "cost": cost, "damping": lam})
        if progress is not None:
            progress(it, np.sqrt(cost / problem.observation.n_items))
        J = problem.jacobian(state, names) * w[:, None]
        svd = ScaledSVD.of(J, scale)
    return state, converged, len(history) - 1, history, total


def solve(problem, start, names, *, max_iter: int = 50, progress=None, **_) -> SolverOutput:
    """Least squares from ``start`` on ``names`` (plus the observation's nuisance)."""
    state, converged, iters, history, _ = gauss_newton(problem, start, names, max_iter=max_iter,
                                                       progress=progress)
    message = (f"converged in {iters} iterations" if converged
               else f"not converged after {max_iter} iterations")
    return SolverOutput(state=state, converged=converged, message=message, history=history)
