"""Empirical Bayes: the prior scale of each parameter group from the data (type-II maximum likelihood).

The calibration linearised at the registered nominal model is ``r = J x + e``: ``r (M,)`` the
weighted residuals, ``J (M, k)`` their Jacobian, ``e ~ N(0, s^2 I)`` and, per column with a prior,
``x_j ~ N(0, (f_g sigma_j)^2)``: ``sigma_j`` its class default (:func:`robocal.identify.priors.prior_sigma`)
and ``f_g`` the widening of its group ``g`` (joint zeros, twists, lengths, joint-error terms);
frames and nuisance have a flat prior. The marginal likelihood (evidence) of the data given
``(f, s)`` is, with ``A = J^T J / s^2 + D`` (``D`` the prior precisions) and ``x*`` the MAP step,

    -2 log p(r | f, s) = M log(2 pi s^2) + |r - J x*|^2 / s^2 + sum_j D_j x*_j^2
                         - sum_j log D_j + log det A            (+ a constant of the flat columns),

exactly ``log N(r; 0, s^2 I + J Sigma J^T)`` without flat columns (MacKay, "Bayesian
interpolation", Neural Computation 4(3), 1992; Bishop, *Pattern Recognition and Machine
Learning*, 2006, sec. 3.5). :func:`fit_group_scales` maximises it over ``log f_g`` and ``log s``
(L-BFGS-B on the k x k normal equations: no (M, k) work per evaluation).

Honesty: a group is only widened (``1 <= f_g <=`` :data:`MAX_WIDENING`), and only where the data
ask for it: a widened group that does not raise the evidence by :data:`EVIDENCE_GAIN_NATS` over
the same fit with that group at its default is set back. A group at the bound is reported: the
data ask for more than any robot of the class carries (another robot, a wrong model, a mistake).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.optimize

EVIDENCE_GAIN_NATS = 3.0  # log Bayes factor a widened group must earn (Kass & Raftery: "strong" from 3)
MAX_WIDENING = 20.0  # largest factor on a class default scale (service class: 60 deg zeros, 200 mm/m)
DIAGNOSIS_WIDENING = 100.0  # the bound of the "what do the data ask for" fit behind the diagnosis
NOISE_SPAN = 8.0  # log-space bound of the noise around its robust start estimate (e^8 either way)
WIDENING_RTOL = 1e-6  # a factor within this relative distance of a bound (or scale) counts as at it
_TINY = 1e-300


@dataclass(frozen=True)
class NormalStats:
    """The linearised problem's sufficient statistics, columns scaled to unit diagonal: ``G (k, k)``
    = J^T J / (c c^T), ``h (k,)`` = J^T r / c, ``rr`` = r^T r, ``M`` rows, ``c (k,)`` column norms."""

    G: np.ndarray
    h: np.ndarray
    rr: float
    M: int
    c: np.ndarray

    @classmethod
    def of(cls, J: np.ndarray, r: np.ndarray) -> NormalStats:
        """From the Jacobian ``J (M, k)`` and residuals ``r (M,)`` (one pass over the rows)."""
        G = J.T @ J
        c = np.sqrt(np.maximum(np.diag(G), _TINY))
        return cls(G / np.outer(c, c), (J.T @ r) / c, float(r @ r), J.shape[0], c)


def log_evidence(stats: NormalStats, precision: np.ndarray, noise: float) -> float:
    """``log p(r | prior, noise)`` (module docstring) for the prior precisions ``precision (k,)``
    (1 / sigma^2 in the columns' units; 0: a flat prior) and the residual scale ``noise``;
    -inf when the posterior precision is singular."""
    s2 = noise**2
    has = precision > 0
    D = precision / stats.c**2  # in the unit-diagonal columns
    A = stats.G / s2 + np.diag(D)
    try:
        factor = scipy.linalg.cho_factor(A)
    except np.linalg.LinAlgError:
        return -np.inf
    x = scipy.linalg.cho_solve(factor, stats.h / s2)
    fit = stats.rr - 2.0 * x @ stats.h + x @ stats.G @ x
    log_det_A = 2.0 * float(np.sum(np.log(np.diag(factor[0])))) + 2.0 * float(np.sum(np.log(stats.c)))
    m2 = (stats.M * np.log(2 * np.pi * s2) + max(fit, 0.0) / s2 + float(D @ x**2)
          - float(np.sum(np.log(precision[has]))) + log_det_A)
    return -0.5 * m2


def map_residual_rms(stats: NormalStats, precision: np.ndarray, noise: float) -> float:
    """RMS of the linear MAP step's residuals (residual unit) with the prior precisions ``precision``."""
    A = stats.G / noise**2 + np.diag(precision / stats.c**2)
    x = np.linalg.solve(A, stats.h / noise**2)
    return float(np.sqrt(max(stats.rr - 2.0 * x @ stats.h + x @ stats.G @ x, 0.0) / stats.M))


@dataclass(frozen=True)
class ScaleFit:
    """The evidence maximisation's answer: the factor on each group's default (1: kept), the
    evidence gain over the defaults (nats), the noise it found (residual unit), the groups at
    :data:`MAX_WIDENING` and the linear MAP residual RMS with the defaults and with the factors."""

    factors: dict
    gain: float
    noise: float
    at_bound: tuple
    rms_default: float
    rms_fitted: float


def fit_group_scales(J: np.ndarray, r: np.ndarray, sigma: np.ndarray, groups, estimated,
                     noise0: float, max_widening: float = MAX_WIDENING,
                     stats: NormalStats | None = None) -> ScaleFit:
    """The widening of each group in ``estimated`` that maximises the evidence of ``J (M, k)``,
    ``r (M,)`` with default prior scales ``sigma (k,)`` (inf: flat) and column groups ``groups``
    (``k`` names, None for flat columns), the noise free around ``noise0`` (residual unit); the
    other groups stay at their scale. See the module docstring for the bounds and the gain test."""
    stats = NormalStats.of(J, r) if stats is None else stats
    sigma = np.asarray(sigma, float)
    groups = np.array([g if g is not None else "" for g in groups], dtype=object)
    wanted = set(estimated)
    free = [g for g in dict.fromkeys(groups) if g and g in wanted]
    base = np.where(np.isfinite(sigma), 1.0 / np.where(np.isfinite(sigma), sigma, 1.0) ** 2, 0.0)
    member = np.array([groups == g for g in free], dtype=float).reshape(len(free), groups.size)
    top = np.log(max_widening)
    log_s0 = np.log(noise0)

    def precision(log_f: np.ndarray) -> np.ndarray:
        return base * np.exp(-2.0 * (log_f @ member)) if free else base

    def cost(z: np.ndarray) -> float:
        value = log_evidence(stats, precision(z[:-1]), float(np.exp(z[-1])))
        return -value if np.isfinite(value) else 1e300

    def best(lo: np.ndarray, hi: np.ndarray, start: np.ndarray) -> np.ndarray:
        z0 = np.r_[np.clip(start[:-1], lo, hi), start[-1]]
        bounds = [*zip(lo, hi, strict=True), (log_s0 - NOISE_SPAN, log_s0 + NOISE_SPAN)]
        return scipy.optimize.minimize(cost, z0, method="L-BFGS-B", bounds=bounds).x

    zeros = np.zeros(len(free))
    z_default = best(zeros, zeros, np.r_[zeros, log_s0])
    z = best(zeros, np.full(len(free), top), z_default)
    cost_z = cost(z)  # kept with z: each evidence once, not again per test and for the gain
    for i in np.argsort(z[:-1]):  # the least widened first: does each group earn its widening?
        hi = np.where(z[:-1] > 0.0, top, 0.0)  # the groups kept at their default so far stay there
        if hi[i] == 0.0:
            continue
        hi[i] = 0.0
        without = best(zeros, hi, z)
        cost_without = cost(without)
        if cost_without - cost_z < EVIDENCE_GAIN_NATS:
            z, cost_z = without, cost_without
    log_f = np.clip(z[:-1], 0.0, top)
    noise = float(np.exp(z[-1]))
    return ScaleFit(factors={g: float(np.exp(v)) for g, v in zip(free, log_f, strict=True)},
                    gain=float(cost(z_default) - cost_z), noise=noise,
                    at_bound=tuple(g for g, v in zip(free, log_f, strict=True) if v >= top - WIDENING_RTOL),
                    rms_default=map_residual_rms(stats, precision(zeros), noise),
                    rms_fitted=map_residual_rms(stats, precision(log_f), noise))
