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
   is ONE vectorised evaluation (``residuals_batch``; plane data: the seed's plane fit per
   individual, ``profiled_residuals_batch``).
5. Roulette-wheel selection on the fitness, single-point crossover of parent pairs with
   probability ``crossover`` (0.8), mutation (binary: each bit flips with probability
   ``mutation``; real: each gene with probability ``mutation`` gets Gaussian noise of 10 % of the
   box half-width), ``elite`` best individuals copied unchanged.
6. Stop when the RMS item error falls to ``threshold`` (m; 0 = never) or after ``generations``.

Ctrl-C during the generations returns the best individual so far (``converged=False``,
message 'interrupted'). The same ``seed`` gives the same result.
"""

from __future__ import annotations

import numpy as np

from robocal.errors import IdentificationError
from robocal.identify.lsq import gauss_newton
from robocal.identify.solvers import SolverOutput
from robocal.progress import Progress


class PopulationCost:
    """Vectorised errors of a population of displacement vectors ``X (P, k)`` of ``names``
    around ``state`` (shared by ``genetic`` and ``swarm``).

    Observations with nuisance parameters must offer ``profiled_residuals_batch`` (the nuisance
    is then fitted per individual, e.g. the seed-004 plane fit); the others use
    ``residuals_batch``.
    """

    def __init__(self, problem, state, names) -> None:
        self.problem, self.state, self.names = problem, state, list(names)
        self.obs = problem.observation
        self.profiled = bool(problem.nuisance_names)
        if self.profiled and not hasattr(self.obs, "profiled_residuals_batch"):
            raise IdentificationError(f"{problem.kind} observations have nuisance parameters but no "
                                      "per-candidate fit: use method 'lsq' or 'robust' for them")
        self.rows = problem.rows_per_item

    def residuals(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residuals ``(P, M)`` and nuisance ``(P, m)`` of each individual."""
        X = np.atleast_2d(X)
        if self.profiled:
            r, nu = self.obs.profiled_residuals_batch(self.state.robot, self.names, X)
            return r / self.problem.sigma, nu
        r = self.problem.residuals_batch(self.state, self.names, X)
        return r, np.broadcast_to(self.state.nuisance, (X.shape[0], self.state.nuisance.size))

    def item_errors(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per-item error norms ``(P, N)`` and nuisance ``(P, m)``."""
        r, nu = self.residuals(X)
        return np.linalg.norm(r.reshape(r.shape[0], -1, self.rows), axis=2), nu

    def state_of(self, x: np.ndarray, nuisance: np.ndarray):
        """The State of one displacement ``x (k,)`` with its nuisance ``(m,)``."""
        dx = np.concatenate([x, np.asarray(nuisance, float) - self.state.nuisance])
        return self.problem.step(self.state, self.names, dx)


def check_bounds(robot, names, bounds) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) displacement bounds ``(k,)``; they must contain 0 (the start model)."""
    k = len(names)
    lo, hi = robot.bounds(names) if bounds is None else (np.asarray(b, float) for b in bounds)
    if np.ndim(lo) not in (0, 1) or np.size(lo) not in (1, k) or np.shape(lo) != np.shape(hi):
        raise IdentificationError(f"bounds must be two scalars or two arrays of {k} values (one per free "
                                  f"parameter: {', '.join(names)})")
    lo, hi = np.broadcast_to(lo, (k,)).astype(float), np.broadcast_to(hi, (k,)).astype(float)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all() and (lo < hi).all()):
        raise IdentificationError("bounds must be finite with lower < upper for every parameter")
    outside = [n for n, a, b in zip(names, lo, hi, strict=True) if not a <= 0.0 <= b]
    if outside:
        raise IdentificationError(f"the bounds of {outside} exclude the nominal value: bounds are "
                                  "displacements from the start model (SI) and must contain 0")
    return lo, hi


def progress_reporter(progress, label: str, total: int):
    """``(bar, report)``: the caller's ``progress(iteration, rms)`` when given (``calibrate(...,
    progress=True)`` draws its own bar through it), else a :class:`Progress` bar of ``total``
    steps with the best RMS error (drawn on a terminal only, silent under ``--quiet``)."""
    bar = Progress(total, label, quiet=True if progress is not None else None)

    def report(iteration: int, rms: float) -> None:
        bar.update(info=f"best rms {rms * 1e3:.5f} mm")
        if progress is not None:
            progress(iteration, rms)
    return bar, report


def _decode(bits: np.ndarray, k: int, nbits: int, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    weights = 2.0 ** np.arange(nbits - 1, -1, -1)
    ints = bits.reshape(bits.shape[0], k, nbits) @ weights
    return lo + (hi - lo) * ints / (2.0**nbits - 1)


def _encode(X: np.ndarray, nbits: int, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    ints = np.rint((X - lo) / (hi - lo) * (2.0**nbits - 1)).astype(np.int64)
    shifts = np.arange(nbits - 1, -1, -1)
    return ((ints[..., None] >> shifts) & 1).astype(bool).reshape(X.shape[0], -1)


def solve(problem, start, names, *, seed: int = 0, progress=None, population: int = 60,
          generations: int = 100, crossover: float = 0.8, mutation: float | None = None,
          elite: int = 2, threshold: float = 0.0, encoding: str = "binary", bits: int = 20,
          spread: float = 0.01, bounds=None, lsq_iter: int = 50, **_) -> SolverOutput:
    """Genetic algorithm around the least-squares solution (module docstring); options as named
    there. ``mutation`` defaults to 1 / chromosome length."""
    names = list(names)
    k = len(names)
    if int(population) < 2:
        raise IdentificationError(f"population must be at least 2, got {population}")
    if not 0.0 <= crossover <= 1.0:
        raise IdentificationError(f"crossover probability must be in [0, 1], got {crossover}")
    if encoding not in ("binary", "real"):
        raise IdentificationError(f"encoding must be 'binary' or 'real', got {encoding!r}")
    if not 2 <= int(bits) <= 52 or int(generations) < 0 or not 0 <= int(elite) < int(population):
        raise IdentificationError("bits must be in [2, 52], generations >= 0, 0 <= elite < population")
    if not spread > 0 or threshold < 0:
        raise IdentificationError("spread must be > 0 and threshold >= 0")
    population, generations, elite, bits = int(population), int(generations), int(elite), int(bits)
    lo, hi = check_bounds(start.robot, names, bounds)
    rng = np.random.default_rng(seed)
    # 1. the least-squares centre, as a displacement from the start
    centre_state, _, lsq_iters, _, total = gauss_newton(problem, start, names, max_iter=lsq_iter)
    centre = np.clip(total[:k], lo, hi)
    half = spread * (hi - lo) / 2
    box_lo, box_hi = np.maximum(centre - half, lo), np.minimum(centre + half, hi)
    X = rng.uniform(box_lo, box_hi, (population, k))
    X[0] = centre
    genes = k * bits if encoding == "binary" else k
    p_mut = 1.0 / max(genes, 1) if mutation is None else float(mutation)
    if not 0.0 <= p_mut <= 1.0:
        raise IdentificationError(f"mutation rate must be in [0, 1], got {mutation}")
    chrom = _encode(X, bits, box_lo, box_hi) if encoding == "binary" else X.copy()

    def decode(c):
        return _decode(c, k, bits, box_lo, box_hi) if encoding == "binary" else c

    cost = PopulationCost(problem, start, names)
    n_items = problem.observation.n_items
    err, nu = cost.item_errors(decode(chrom))
    mu = err.sum(axis=1)
    best = int(np.argmin(mu))
    best_x, best_nu, best_mu = decode(chrom)[best].copy(), nu[best].copy(), mu[best]
    best_rms = float(np.sqrt(np.mean(err[best] ** 2)))
    history = [{"iteration": 0, "cost": float(best_mu), "rms": best_rms}]
    message, converged, gen = "", False, 0
    bar, report = progress_reporter(progress, "genetic", generations)
    with bar:
        try:
            for gen in range(1, generations + 1):
                if threshold and best_rms <= threshold:
                    break
                fitness = 1.0 / np.maximum(mu, 1e-300)
                order = np.argsort(mu)
                elites = chrom[order[:elite]]
                # roulette wheel: cumulative probabilities, one uniform number per child slot
                cum = np.cumsum(fitness / fitness.sum())
                picks = np.minimum(np.searchsorted(cum, rng.random(population - elite + 1)), population - 1)
                parents = chrom[picks]
                n_pairs = (population - elite + 1) // 2
                a, b = parents[0:2 * n_pairs:2], parents[1:2 * n_pairs:2]
                cut = rng.integers(1, genes, n_pairs) if genes > 1 else np.ones(n_pairs, int)
                do = rng.random(n_pairs) < crossover
                tail = (np.arange(genes)[None, :] >= cut[:, None]) & do[:, None]
                child1 = np.where(tail, b, a)
                child2 = np.where(tail, a, b)
                children = np.concatenate([child1, child2])[: population - elite]
                flip = rng.random(children.shape) < p_mut
                if encoding == "binary":
                    children = children ^ flip
                else:
                    noise = rng.standard_normal(children.shape) * 0.1 * (box_hi - box_lo) / 2
                    children = np.clip(np.where(flip, children + noise, children), box_lo, box_hi)
                chrom = np.concatenate([elites, children])
                err, nu = cost.item_errors(decode(chrom))
                mu = err.sum(axis=1)
                i = int(np.argmin(mu))
                if mu[i] < best_mu:
                    best_x, best_nu, best_mu = decode(chrom)[i].copy(), nu[i].copy(), mu[i]
                    best_rms = float(np.sqrt(np.mean(err[i] ** 2)))
                history.append({"iteration": gen, "cost": float(best_mu), "rms": best_rms})
                report(gen, best_rms)
            else:
                gen = generations
        except KeyboardInterrupt:
            message = "interrupted"
    if not message:
        converged = bool(threshold) and best_rms <= threshold
        message = (f"error threshold reached after {gen} generations" if converged
                   else f"generation limit {generations} reached (best rms {best_rms:.6g}, "
                        f"{n_items} items)")
    state = cost.state_of(best_x, best_nu)
    return SolverOutput(state=state, converged=converged or (not threshold and message != "interrupted"),
                        message=message, history=history,
                        extra={"lsq_iterations": lsq_iters, "lsq_state": centre_state,
                               "encoding": encoding, "generations": gen, "best_mu": float(best_mu)})
