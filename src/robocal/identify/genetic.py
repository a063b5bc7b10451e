"""Method ``genetic`` (seed 000, steps 6-7, embodiments 5-6): a genetic algorithm around the
least-squares solution.

1. Least squares (:func:`robocal.identify.lsq.gauss_newton`) gives the centre.
2. The search box is the centre +- ``spread`` times the parameter bounds' half-widths, clipped to
   the bounds (``bounds``: (lower, upper) displacements from the start model, SI; default
   :meth:`Robot.bounds`). The initial population is uniform in the box plus the centre itself.
3. Encoding: ``binary`` (the seed's: each parameter quantised over the box with ``bits`` bits,
   the chromosome is the concatenated bit string) or ``real`` (one float gene per parameter).
4. Fitness = 1 / mu, mu the summed error: sum over measurement items of the norm of the item's
   (weighted) residuals — for tracker points the summed position error (m). The whole population
   is ONE vectorised evaluation (``profiled_residuals_batch``; plane data: the seed's plane fit
   per individual).
5. Roulette-wheel selection on the fitness, single-point crossover of parent pairs with
   probability ``crossover`` (0.8), mutation (binary: each bit flips with probability
   ``mutation``; real: each gene with probability ``mutation`` gets Gaussian noise of 10 % of the
   box half-width), ``elite`` best individuals copied unchanged.
6. Stop when the RMS item error falls to ``threshold`` (m; 0 = never; status ``threshold``), when
   the best mu improved by less than ``ftol`` (relative) over the last ``patience`` generations
   (the convergence test; 0 = never; status ``converged``), or after ``generations`` (status
   ``max_iterations``: not a success). The default ``ftol`` 1e-4 is what a stochastic search can
   resolve: around the least-squares centre the best mu keeps creeping by 1e-6..1e-5 of itself per
   generation (the GA minimises the summed error, not the squares), which no accuracy figure shows.

Ctrl-C during the generations returns the best individual so far (status ``interrupted``). The
same ``seed`` gives the same result.
"""

from __future__ import annotations

import numpy as np

from robocal.core.errors import IdentificationError
from robocal.identify.lsq import gauss_newton
from robocal.identify.population import PopulationCost, evolve, stop_message
from robocal.identify.solvers import SolverResult
from robocal.identify.space import ParameterSpace, State


def _decode(bits: np.ndarray, k: int, nbits: int, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    weights = 2.0 ** np.arange(nbits - 1, -1, -1)
    ints = bits.reshape(bits.shape[0], k, nbits) @ weights
    return lo + (hi - lo) * ints / (2.0**nbits - 1)


def _encode(X: np.ndarray, nbits: int, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    ints = np.rint((X - lo) / (hi - lo) * (2.0**nbits - 1)).astype(np.int64)
    shifts = np.arange(nbits - 1, -1, -1)
    return ((ints[..., None] >> shifts) & 1).astype(bool).reshape(X.shape[0], -1)


def _check(population, generations, crossover, mutation, elite, encoding, bits, spread, threshold) -> None:
    if int(population) < 2:
        raise IdentificationError(f"population must be at least 2, got {population}")
    if not 0.0 <= crossover <= 1.0:
        raise IdentificationError(f"crossover probability must be in [0, 1], got {crossover}")
    if mutation is not None and not 0.0 <= mutation <= 1.0:
        raise IdentificationError(f"mutation rate must be in [0, 1], got {mutation}")
    if encoding not in ("binary", "real"):
        raise IdentificationError(f"encoding must be 'binary' or 'real', got {encoding!r}")
    if not 2 <= int(bits) <= 52 or int(generations) < 0 or not 0 <= int(elite) < int(population):
        raise IdentificationError("bits must be in [2, 52], generations >= 0, 0 <= elite < population")
    if not spread > 0 or threshold < 0:
        raise IdentificationError("spread must be > 0 and threshold >= 0")


def _offspring(chrom: np.ndarray, mu: np.ndarray, rng: np.random.Generator, *, elite: int,
               crossover: float, p_mut: float, binary: bool, box_lo, box_hi) -> np.ndarray:
    """The next generation: the ``elite`` best unchanged, the rest by roulette-wheel selection
    (fitness 1 / mu), single-point crossover and mutation."""
    population, genes = chrom.shape
    fitness = 1.0 / np.maximum(mu, 1e-300)
    elites = chrom[np.argsort(mu)[:elite]]
    # roulette wheel: cumulative probabilities, one uniform number per child slot
    cum = np.cumsum(fitness / fitness.sum())
    picks = np.minimum(np.searchsorted(cum, rng.random(population - elite + 1)), population - 1)
    parents = chrom[picks]
    n_pairs = (population - elite + 1) // 2
    a, b = parents[0:2 * n_pairs:2], parents[1:2 * n_pairs:2]
    cut = rng.integers(1, genes, n_pairs) if genes > 1 else np.ones(n_pairs, int)
    do = rng.random(n_pairs) < crossover
    tail = (np.arange(genes)[None, :] >= cut[:, None]) & do[:, None]
    children = np.concatenate([np.where(tail, b, a), np.where(tail, a, b)])[: population - elite]
    flip = rng.random(children.shape) < p_mut
    if binary:
        children = children ^ flip
    else:
        noise = rng.standard_normal(children.shape) * 0.1 * (box_hi - box_lo) / 2
        children = np.clip(np.where(flip, children + noise, children), box_lo, box_hi)
    return np.concatenate([elites, children])


def solve(problem, start: State, space: ParameterSpace, *, seed: int = 0, progress=None,
          population: int = 60, generations: int = 100, crossover: float = 0.8,
          mutation: float | None = None, elite: int = 2, threshold: float = 0.0,
          patience: int = 20, ftol: float = 1e-4, encoding: str = "binary", bits: int = 20,
          spread: float = 0.01, bounds=None, lsq_iter: int = 50, **_) -> SolverResult:
    """Genetic algorithm around the least-squares solution (module docstring); options as named
    there. ``mutation`` defaults to 1 / chromosome length."""
    _check(population, generations, crossover, mutation, elite, encoding, bits, spread, threshold)
    population, generations, elite, bits = int(population), int(generations), int(elite), int(bits)
    k = len(space.robot)
    lo, hi = space.robot_bounds(start.robot, bounds)
    rng = np.random.default_rng(seed)
    # the least-squares centre, as a displacement from the start
    centre = np.clip(gauss_newton(problem, start, space, max_iter=lsq_iter).total[:k], lo, hi)
    half = spread * (hi - lo) / 2
    box_lo, box_hi = np.maximum(centre - half, lo), np.minimum(centre + half, hi)
    X = rng.uniform(box_lo, box_hi, (population, k))
    X[0] = centre
    binary = encoding == "binary"
    genes = k * bits if binary else k
    p_mut = 1.0 / max(genes, 1) if mutation is None else float(mutation)
    chrom = _encode(X, bits, box_lo, box_hi) if binary else X.copy()

    def decode(c):
        return _decode(c, k, bits, box_lo, box_hi) if binary else c

    cost = PopulationCost(problem, start, space)
    best: dict = {}

    def evaluate() -> np.ndarray:
        """mu ``(population,)`` of the current chromosomes; keeps the best individual so far."""
        X = decode(chrom)
        err, nu = cost.item_errors(X)
        mu = err.sum(axis=1)
        i = int(np.argmin(mu))
        if not best or mu[i] < best["mu"]:
            best.update(x=X[i].copy(), nu=nu[i].copy(), mu=mu[i], ss=float(np.sum(err[i] ** 2)))
        return mu

    mu = evaluate()

    def generation(_: int) -> tuple[float, float]:
        nonlocal chrom, mu
        chrom = _offspring(chrom, mu, rng, elite=elite, crossover=crossover, p_mut=p_mut, binary=binary,
                           box_lo=box_lo, box_hi=box_hi)
        mu = evaluate()
        return best["ss"], best["mu"]

    status, gen, history = evolve(generation, initial_cost=best["ss"], n_items=problem.n_items,
                                  limit=generations, threshold=threshold, patience=patience, ftol=ftol,
                                  progress=progress, label="genetic")
    message = stop_message(status, "generation", gen, generations, history[-1]["rms"], problem.n_items)
    return SolverResult(state=cost.state_of(best["x"], best["nu"]), status=status, message=message, nit=gen,
                        history=history)
