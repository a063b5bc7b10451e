"""Parameter priors: how far a real robot can be from its nominal model, and what the data add.

Every robot parameter a calibration estimates carries a prior: the nominal value and a 1-sigma
scale of how far a real robot of its size can be off (:func:`prior_sigma`). The estimate is the
maximum a-posteriori (MAP) one, regularised least squares with one pseudo-observation row per
parameter, ``noise * (value - nominal) / sigma`` in the residuals' unit (``noise``: the residual
scale of one measurement row, estimated from the data by :func:`linear_analysis`). A parameter the
data determine moves freely; one they cannot determine stays near nominal instead of wandering
along a null direction. This is seed 003's ridge step with a physical, per-parameter ridge.

The scales (1 sigma, :data:`LINK_LENGTH_MM_PER_M` etc.) are deliberately generous: they are the
size of the corrections published calibrations of industrial arms identify, not the machining
tolerances of the parts. Sources: Mooring, Roth & Driels, *Fundamentals of Manipulator
Calibration* (Wiley 1991), ch. 1 and 5 (link length errors of tenths of a millimetre to a few
millimetres, twist errors of hundredths to tenths of a degree, joint zero offsets dominating at
up to a degree after remastering); Judd & Knasinski, "A technique to calibrate industrial robots
with experimental verification", IEEE Trans. Robotics and Automation 6(1), 1990 (joint offsets
the largest error source); Nubiola & Bonev, "Absolute calibration of an ABB IRB 1600 robot using a
laser tracker", Robotics and Computer-Integrated Manufacturing 29(1), 2013 (identified MDH
corrections below 1 mm and 0.1 deg; compliance and gear terms of hundredths of a degree). The
simulator's robots (:mod:`robocal.data.simulate`: 0.05-0.5 mm, 0.005-0.05 deg) are well inside.
Frames (base, tool, extra SMRs) and nuisance parameters (planes) have no prior: registration
and the data fix them. See docs/priors.md.

A parameter whose posterior sigma is more than :data:`NOT_DETERMINED_RATIO` of its prior sigma is
*not determined by these data* (the data carry less than a third of the prior's information on
it): it is held at nominal and reported with the parameters it is confounded with.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.identify.linalg import ScaledSVD
from robocal.identify.robust import MAD_TO_SIGMA
from robocal.identify.space import block_of
from robocal.kinematics.joint_errors import term_of

LINK_LENGTH_MIN_MM = 0.5  # a, d: at least this (1 sigma) ...
LINK_LENGTH_MM_PER_M = 1.0  # ... and this per metre of the arm's summed link lengths (size class)
LINK_ANGLE_DEG = 0.2  # alpha, beta: axis misalignments
JOINT_ZERO_DEG = 0.5  # theta: joint zero offsets (mastering)
# Scale (a joint's encoder / transmission ratio, mostly a linear track's): 1 sigma 5e-4 m/m. A
# track's rack pitch and encoder scale are within ~1e-4 (ISO 230-2 positioning accuracy of long
# machine axes: 0.1-0.3 mm per metre before compensation) and steel grows 1.2e-5 per kelvin (1e-4
# for a 10 K warmer hall); 5e-4 covers both with margin (the simulator's 2e-4 is inside).
JOINT_ERROR_SIGMA = {"gear": np.deg2rad(0.2), "cyclic": np.deg2rad(0.2), "backlash": np.deg2rad(0.2),
                     "travel": 0.01, "compliance": 0.01,
                     "scale": 5e-4,
                     # payload: a 10 kg m payload moment turns a joint by up to ~1e-3 rad (small arms
                     # are the softest per kg m); thermal: steel 11.5e-6/K, aluminium 23e-6/K; a link
                     # group's deviation from the shared k: the steel-aluminium difference 11.5e-6/K
                     "payload": 1e-4, "thermal": 30e-6,
                     "thermal_groups": 12e-6}  # SI units: rad, rad/rad, rad/m, 1, rad/(kg m), 1/K
NOT_DETERMINED_RATIO = 0.5  # posterior sigma / prior sigma above which the data do not determine it
NOISE_RTOL = 0.05  # the noise estimate has settled when it changes by less than this fraction
NOISE_MAX_PASSES = 10


def prior_sigma(robot, names) -> np.ndarray:
    """1-sigma prior scale ``(k,)`` (SI) of each named robot parameter; ``inf`` for frames and SMR
    offsets (no prior)."""
    link_mm = max(LINK_LENGTH_MIN_MM, LINK_LENGTH_MM_PER_M * (np.abs(robot.a).sum() + np.abs(robot.d).sum()))
    out = []
    for name in names:
        block = block_of(name)
        if block == "links":
            kind = name.rstrip("0123456789")
            out.append(link_mm * 1e-3 if kind in ("a", "d") else
                       np.deg2rad(JOINT_ZERO_DEG if kind == "theta" else LINK_ANGLE_DEG))
        elif block == "joint_errors":
            out.append(JOINT_ERROR_SIGMA[term_of(name)])
        else:
            out.append(np.inf)
    return np.array(out, dtype=float)


@dataclass(frozen=True)
class LinearAnalysis:
    """The MAP problem linearised at the start: the noise estimate (residual unit), the posterior
    covariance ``(k, k)`` (SI) and each unknown's posterior / prior sigma ratio (nan: no prior)."""

    noise: float
    covariance: np.ndarray
    ratio: np.ndarray


def posterior_covariance(J: np.ndarray, weight: np.ndarray, s0: float) -> np.ndarray:
    """``s0^2 (J^T J + diag(weight^2))^-1`` ``(k, k)`` for the Jacobian ``J (M, k)`` (residual unit
    per SI unit) and prior row weights ``weight (k,)`` (0: no prior); pseudo-inverse on the
    directions neither determines."""
    k = J.shape[1]
    A = np.vstack([J, np.diag(weight)[weight > 0]]) if np.any(weight > 0) else J
    svd = ScaledSVD.of(A)
    inv_s = np.where(svd.s > 1e-12 * svd.s[0], 1.0 / svd.s, 0.0) if k else svd.s
    V = svd.Vt.T * inv_s
    return s0**2 * (V @ V.T) / np.outer(svd.scale, svd.scale)


def _scale(rest: np.ndarray, J: np.ndarray, blocks) -> float:
    """Robust residual scale of ``rest (M,)``: per block of rows (measurement set) the median
    absolute value (to sigma, for the block's share of the k unknowns: dof M_b - k_b), combined
    weighted by each block's information ``|J_b|^2`` (a set that carries no information, e.g. a
    huge sigma, does not pull the scale)."""
    info = np.array([float(np.sum(J[rows] ** 2)) for rows in blocks])
    share = J.shape[1] * info / max(info.sum(), 1e-300)
    var = [(MAD_TO_SIGMA * float(np.median(np.abs(rest[rows])))) ** 2 * len(rows) / max(len(rows) - k, 1)
           if len(rows) else 0.0 for rows, k in zip(blocks, share, strict=True)]
    return float(np.sqrt(np.sum(info * np.asarray(var)) / max(info.sum(), 1e-300)))


def linear_analysis(J: np.ndarray, r: np.ndarray, sigma: np.ndarray, noise0: float,
                    blocks=None) -> LinearAnalysis:
    """One linear MAP step from the start (the prior mean) on ``J (M, k)``, ``r (M,)`` with prior
    scales ``sigma (k,)`` (SI, inf: none): the residual scale is re-estimated from the step's
    residuals (their median absolute value, so outliers do not inflate it; dof M - k) until it
    settles (starting from ``noise0``), then the posterior. ``blocks``: the row indices of each
    measurement set (default: one set)."""
    M, k = J.shape
    blocks = [np.arange(M)] if blocks is None else blocks
    has = np.isfinite(sigma)
    inv = 1.0 / np.asarray(sigma, float)  # 0 where there is no prior (sigma inf)
    noise = noise0
    for _ in range(NOISE_MAX_PASSES):
        w = noise * inv
        A = np.vstack([J, np.diag(w)[has]])
        b = np.concatenate([r, np.zeros(int(has.sum()))])
        step = ScaledSVD.of(A).solve(b)
        rest = r - J @ step  # its robust scale (MAD): a few gross errors must not weaken the data
        new = _scale(rest, J, blocks)
        settled = abs(new - noise) <= NOISE_RTOL * noise
        noise = max(new, 1e-12 * noise0)
        if settled:
            break
    cov = posterior_covariance(J, noise * inv, noise)
    post = np.sqrt(np.maximum(np.diag(cov), 0.0))
    ratio = np.where(has, post * inv, np.nan)
    return LinearAnalysis(noise, cov, ratio)


def undetermined(J: np.ndarray, sigma: np.ndarray, noise: float) -> tuple[list[int], np.ndarray]:
    """The columns of ``J (M, k)`` to hold, one at a time: the one whose posterior / prior sigma
    ratio is highest, while it exceeds :data:`NOT_DETERMINED_RATIO`, the posterior recomputed
    without it (so of a confounded group only as many are held as the data cannot separate: the
    determined combinations stay estimated). Returns the held indices and every column's ratio at
    the step it was held (or in the final set; nan without a prior)."""
    has = np.isfinite(sigma)
    inv = 1.0 / np.asarray(sigma, float)  # 0 where there is no prior (sigma inf)
    free = np.arange(J.shape[1])
    held: list[int] = []
    ratio = np.full(J.shape[1], np.nan)
    while free.size:
        cov = posterior_covariance(J[:, free], noise * inv[free], noise)
        q = np.where(has[free], np.sqrt(np.maximum(np.diag(cov), 0.0)) * inv[free], np.nan)
        ratio[free] = q
        worst = int(np.nanargmax(q)) if np.isfinite(q).any() else -1
        if worst < 0 or q[worst] <= NOT_DETERMINED_RATIO:
            break
        held.append(int(free[worst]))
        free = np.delete(free, worst)
    return held, ratio
