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
observation type works. Stops when the RMS item error reaches ``threshold`` (m; 0 = never;
status ``threshold``), when the best cost improved by less than ``ftol`` (relative) over the last
``patience`` iterations (the convergence test; 0 = never; ``converged``), or at ``iterations``
(``max_iterations``: not a success). With ``polish`` the cost the convergence test watches is the
global best's *basin*: the cost a least-squares polish from it reaches (recomputed every
``POLISH_EVERY`` iterations): a swarm in 30-odd dimensions creeps towards the bottom for
thousands of iterations, but it has done its job (a global search) once ``patience`` iterations
find no better basin than the one it has.

``polish`` (default True): a short least-squares run (:func:`robocal.identify.lsq.gauss_newton`,
at most ``polish_iter`` iterations) from the best particle. A swarm finds the basin but converges
slowly inside it (the free parameters span 5 mm / 1 deg boxes while the answer must be right to
micrometres); the polish takes it to the bottom. ``polish=False`` gives the seed's pure PSO
result; with the polish the status is the polish's. Ctrl-C during the iterations returns the best
particle so far, unpolished (status ``interrupted``). The same ``seed`` gives the same result.
"""

from __future__ import annotations

import numpy as np

from robocal.core.damped_least_squares import Status
from robocal.core.errors import IdentificationError
from robocal.identify.lsq import gauss_newton
from robocal.identify.population import PopulationCost, evolve, stop_message
from robocal.identify.solvers import SolverResult
from robocal.identify.space import ParameterSpace, State

POLISH_EVERY = 10  # iterations between two polishes of the global best (the basin test)


def solve(problem, start: State, space: ParameterSpace, *, seed: int = 0, progress=None,
          particles: int = 60, iterations: int = 300, inertia: float = 0.7298, c1: float = 1.49618,
          c2: float = 1.49618, vmax: float = 0.2, threshold: float = 0.0, patience: int = 50,
          ftol: float = 1e-9, bounds=None, polish: bool = True, polish_iter: int = 20,
          **_) -> SolverResult:
    """Particle swarm (module docstring); the defaults are Clerc's constriction coefficients."""
    k = len(space.robot)
    if int(particles) < 2 or int(iterations) < 0:
        raise IdentificationError(f"particles must be >= 2 and iterations >= 0, got {particles}, "
                                  f"{iterations}")
    if not (0 < vmax <= 1 and inertia >= 0 and c1 >= 0 and c2 >= 0 and threshold >= 0):
        raise IdentificationError("swarm needs 0 < vmax <= 1 and inertia, c1, c2, threshold >= 0")
    particles, iterations = int(particles), int(iterations)
    lo, hi = space.robot_bounds(start.robot, bounds)
    rng = np.random.default_rng(seed)
    cost = PopulationCost(problem, start, space)
    vclamp = vmax * (hi - lo)
    X = rng.uniform(lo, hi, (particles, k))
    X[0] = 0.0
    V = rng.uniform(-vclamp, vclamp, (particles, k))
    pbest, pbest_f = X.copy(), np.full(particles, np.inf)
    best: dict = {}

    def evaluate() -> None:
        """Cost of the current positions: update the personal and the global bests."""
        f, nu = cost.sum_squares(X)
        better = f < pbest_f
        pbest[better], pbest_f[better] = X[better], f[better]
        g = int(np.argmin(f))
        if not best or f[g] < best["f"]:
            best.update(x=X[g].copy(), f=f[g], nu=nu[g].copy())

    evaluate()
    basin: dict = {}

    def polished():
        """The least-squares polish from the global best (kept until the best changes)."""
        if basin.get("x") is not best["x"]:
            basin.update(x=best["x"], gn=gauss_newton(problem, cost.state_of(best["x"], best["nu"]), space,
                                                      max_iter=polish_iter))
        return basin["gn"]

    def fly(it: int) -> tuple[float, float]:
        nonlocal X, V
        r1, r2 = rng.random((particles, k)), rng.random((particles, k))
        V = np.clip(inertia * V + c1 * r1 * (pbest - X) + c2 * r2 * (best["x"] - X), -vclamp, vclamp)
        X = np.clip(X + V, lo, hi)
        evaluate()
        if not polish:
            return best["f"], best["f"]
        if it % POLISH_EVERY == 1 or "gn" not in basin:
            basin["cost"] = polished().history[-1]["cost"]
        return best["f"], basin["cost"]

    status, it, history = evolve(fly, initial_cost=best["f"], n_items=problem.n_items, limit=iterations,
                                 threshold=threshold, patience=patience, ftol=ftol, progress=progress,
                                 label="swarm")
    state = cost.state_of(best["x"], best["nu"])
    message = (
        f"converged after {it} iterations (no better basin found in the last {patience})"
        if polish and status is Status.CONVERGED else
        stop_message(status, "iteration", it, iterations, history[-1]["rms"], problem.n_items))
    if status is Status.INTERRUPTED or not polish:
        return SolverResult(state=state, status=status, message=message, nit=it, history=history)
    gn = polished()
    history += [{**h, "iteration": it + h["iteration"]} for h in gn.history[1:]]
    message += f"; least-squares polish: {gn.status.value} after {gn.nit} iterations"
    return SolverResult(state=gn.state, status=gn.status, message=message, nit=it + gn.nit,
                        history=history)
