"""Method ``swarm`` (seed 004): particle swarm optimisation over the free parameters.

Particles are displacement vectors of the free parameters from the start model, inside
``bounds`` ((lower, upper), SI; default :meth:`Robot.bounds`, links 5 mm / 1 deg). Particle 0
starts at the start model, the others uniformly in the bounds. Each iteration, for all particles
at once::

    v <- inertia v + c1 r1 (personal best - x) + c2 r2 (global best - x),  |v| <= vmax (upper - lower)
    x <- clip(x + v, lower, upper)

with r1, r2 uniform in [0, 1) per particle and coordinate. The cost is the sum of squared
(weighted) residuals, evaluated for the whole swarm in one vectorised call; on plane contacts the
planes are fitted per particle inside the cost (the seed's least-squares plane fit), so any
observation type works. Stops at ``iterations`` or when the RMS item error reaches ``threshold``
(m; 0 = never).

``polish`` (default True): a short least-squares run (:func:`robocal.identify.lsq.gauss_newton`,
at most ``polish_iter`` iterations) from the best particle. A swarm finds the basin but converges
slowly inside it (the free parameters span 5 mm / 1 deg boxes while the answer must be right to
micrometres); the polish takes it to the bottom. ``polish=False`` gives the seed's pure PSO
result. Ctrl-C during the iterations returns the best particle so far, unpolished
(``converged=False``, message 'interrupted'). The same ``seed`` gives the same result.
"""

from __future__ import annotations

import numpy as np

from robocal.errors import IdentificationError
from robocal.identify.genetic import PopulationCost, check_bounds, progress_reporter
from robocal.identify.lsq import gauss_newton
from robocal.identify.solvers import SolverOutput


def solve(problem, start, names, *, seed: int = 0, progress=None, particles: int = 60,
          iterations: int = 300, inertia: float = 0.7298, c1: float = 1.49618, c2: float = 1.49618,
          vmax: float = 0.2, threshold: float = 0.0, bounds=None, polish: bool = True,
          polish_iter: int = 20, **_) -> SolverOutput:
    """Particle swarm (module docstring); the defaults are Clerc's constriction coefficients."""
    names = list(names)
    k = len(names)
    if int(particles) < 2 or int(iterations) < 0:
        raise IdentificationError(f"particles must be >= 2 and iterations >= 0, got {particles}, "
                                  f"{iterations}")
    if not (0 < vmax <= 1 and inertia >= 0 and c1 >= 0 and c2 >= 0 and threshold >= 0):
        raise IdentificationError("swarm needs 0 < vmax <= 1 and inertia, c1, c2, threshold >= 0")
    particles, iterations = int(particles), int(iterations)
    lo, hi = check_bounds(start.robot, names, bounds)
    rng = np.random.default_rng(seed)
    cost = PopulationCost(problem, start, names)
    vclamp = vmax * (hi - lo)
    X = rng.uniform(lo, hi, (particles, k))
    X[0] = 0.0
    V = rng.uniform(-vclamp, vclamp, (particles, k))

    def evaluate(X):
        err, nu = cost.item_errors(X)
        return np.sum(err**2, axis=1), nu, err.shape[1]

    f, nu, n_items = evaluate(X)
    pbest, pbest_f = X.copy(), f.copy()
    g = int(np.argmin(f))
    gbest, gbest_f, gbest_nu = X[g].copy(), f[g], nu[g].copy()

    def rms(c):
        return float(np.sqrt(c / n_items))

    history = [{"iteration": 0, "cost": float(gbest_f), "rms": rms(gbest_f)}]
    bar, report = progress_reporter(progress, "swarm", iterations)
    interrupted, it = False, 0
    with bar:
        try:
            for it in range(1, iterations + 1):
                if threshold and rms(gbest_f) <= threshold:
                    break
                r1, r2 = rng.random((particles, k)), rng.random((particles, k))
                V = inertia * V + c1 * r1 * (pbest - X) + c2 * r2 * (gbest - X)
                V = np.clip(V, -vclamp, vclamp)
                X = np.clip(X + V, lo, hi)
                f, nu, _ = evaluate(X)
                better = f < pbest_f
                pbest[better], pbest_f[better] = X[better], f[better]
                g = int(np.argmin(f))
                if f[g] < gbest_f:
                    gbest, gbest_f, gbest_nu = X[g].copy(), f[g], nu[g].copy()
                history.append({"iteration": it, "cost": float(gbest_f), "rms": rms(gbest_f)})
                report(it, rms(gbest_f))
        except KeyboardInterrupt:
            interrupted = True
    state = cost.state_of(gbest, gbest_nu)
    extra = {"swarm_state": state, "swarm_rms": rms(gbest_f), "iterations": it}
    if interrupted:
        return SolverOutput(state=state, converged=False, message="interrupted", history=history,
                            extra=extra)
    reached = bool(threshold) and rms(gbest_f) <= threshold
    message = (f"swarm: error threshold reached after {it} iterations" if reached
               else f"swarm: {iterations} iterations, best rms {rms(gbest_f):.6g}")
    if polish:
        state, ok, n_polish, hist, _ = gauss_newton(problem, state, names, max_iter=polish_iter)
        last = history[-1]["iteration"]
        history += [{"iteration": last + h["iteration"], "cost": h["cost"], "stage": "polish"}
                    for h in hist[1:]]
        message += f"; least-squares polish: {n_polish} iterations"
        extra["polish_iterations"] = n_polish
        return SolverOutput(state=state, converged=ok, message=message, history=history, extra=extra)
    return SolverOutput(state=state, converged=reached or not threshold, message=message,
                        history=history, extra=extra)
