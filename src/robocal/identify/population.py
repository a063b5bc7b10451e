"""What the population methods (``genetic``, ``swarm``) share: the vectorised cost of a whole
population and the generational loop with its stopping rules (error threshold, stagnation as the
convergence test, iteration limit, Ctrl-C), history and progress report."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robocal.core.damped_least_squares import Status
from robocal.core.progress import Progress
from robocal.identify.solvers import history_entry
from robocal.identify.space import ParameterSpace, State


class PopulationCost:
    """Vectorised errors of a population of robot displacements ``X (P, k)`` (the robot names of
    ``space``) around ``state``. Measurement sets with nuisance parameters (plane coefficients)
    have them fitted per individual (the seed-004 plane fit). The space's prior
    (:meth:`ParameterSpace.prior_residuals`) adds its rows to every individual's cost: to the sum
    of squares, and as one more item (the norm of the prior rows) to the summed item error."""

    def __init__(self, problem, state: State, space: ParameterSpace) -> None:
        self.problem, self.state, self.space = problem, state, space
        self.names = list(space.robot)
        k = len(self.names)
        self.prior_weight = space.prior_weight[:k]
        self.prior_at_start = space.prior_residuals(state)[:k]  # prior rows at X = 0

    def prior_rows(self, X: np.ndarray) -> np.ndarray:
        """``(P, k)`` prior rows of each displacement (0 where a parameter has no prior)."""
        return self.prior_at_start - self.prior_weight * np.atleast_2d(X)

    def residuals(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residuals ``(P, M)`` and nuisance ``(P, m)`` of each individual."""
        return self.problem.profiled_residuals_batch(self.state.robot, self.names, np.atleast_2d(X))

    def item_errors(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per-item error norms ``(P, N)`` and nuisance ``(P, m)``."""
        r, nu = self.residuals(X)
        prior = np.linalg.norm(self.prior_rows(X), axis=1)[:, None]
        return np.hstack([np.sqrt(self.problem.item_sum_squares(r)), prior]), nu

    def sum_squares(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted sum of squares ``(P,)`` (the history's cost) and nuisance ``(P, m)``."""
        r, nu = self.residuals(X)
        return np.sum(r**2, axis=-1) + np.sum(self.prior_rows(X) ** 2, axis=-1), nu

    def state_of(self, x: np.ndarray, nuisance: np.ndarray) -> State:
        """The State of one displacement ``x (k,)`` with its nuisance ``(m,)``."""
        dx = np.concatenate([x, np.asarray(nuisance, float) - self.state.nuisance])
        return self.space.apply(self.state, dx)


class Stagnation:
    """The population methods' convergence test: the best cost improved by less than ``ftol``
    (relative) over the last ``patience`` iterations (``patience`` 0: never)."""

    def __init__(self, patience: int, ftol: float) -> None:
        self.patience, self.ftol = int(patience), float(ftol)
        self.best: list[float] = []

    def update(self, best_cost: float) -> bool:
        """Record this iteration's best cost; True when the population has stagnated."""
        self.best.append(float(best_cost))
        if self.patience < 1 or len(self.best) <= self.patience:
            return False
        old = self.best[-1 - self.patience]
        return old - self.best[-1] <= self.ftol * max(abs(old), 1e-300)


def evolve(advance: Callable[[int], tuple[float, float]], *, initial_cost: float, n_items: int,
           limit: int, threshold: float, patience: int, ftol: float, progress, label: str
           ) -> tuple[Status, int, list[dict]]:
    """Run ``advance(iteration) -> (best cost, best objective)`` for iterations 1..``limit``.

    Stops when the best RMS item error is at most ``threshold`` (``threshold``; 0 = never), when
    the best objective stagnates (:class:`Stagnation`; ``converged``), at the limit
    (``max_iterations``) or on Ctrl-C (``interrupted``). ``cost`` is the weighted sum of squares of
    the best individual (the history's), ``objective`` what the method minimises. Progress goes to
    the caller's ``progress(iteration, rms)`` when given (``calibrate(..., progress=True)`` draws its
    own bar through it), else to a bar drawn on a terminal only. Returns (status, iterations run,
    history)."""
    history = [history_entry(0, initial_cost, n_items)]
    stagnation = Stagnation(patience, ftol)
    status, it = Status.MAX_ITERATIONS, 0
    with Progress(limit, label, quiet=True if progress is not None else None) as bar:
        try:
            for it in range(1, limit + 1):
                if threshold and history[-1]["rms"] <= threshold:
                    status, it = Status.THRESHOLD, it - 1
                    break
                cost, objective = advance(it)
                history.append(history_entry(it, cost, n_items))
                bar.update(info=f"best rms {history[-1]['rms'] * 1e3:.5f} mm")
                if progress is not None:
                    progress(it, history[-1]["rms"])
                if stagnation.update(objective):
                    status = Status.CONVERGED
                    break
            else:
                if threshold and history[-1]["rms"] <= threshold:
                    status = Status.THRESHOLD
        except KeyboardInterrupt:
            status = Status.INTERRUPTED
    return status, it, history


def stop_message(status: Status, unit: str, it: int, limit: int, rms: float, n_items: int) -> str:
    """How a population method stopped, for the result's message."""
    return {Status.THRESHOLD: f"error threshold reached after {it} {unit}s",
            Status.CONVERGED: f"converged after {it} {unit}s (the best stopped improving; best rms "
                              f"{rms:.6g})",
            Status.MAX_ITERATIONS: f"stopped at the {unit} limit {limit} (best rms {rms:.6g}, "
                                   f"{n_items} items)",
            Status.INTERRUPTED: "interrupted"}[status]
