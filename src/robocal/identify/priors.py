"""Parameter priors: how far a real robot can be from its nominal model, and what the data add.

Every robot parameter a calibration estimates carries a prior: the nominal value and a 1-sigma
scale of how far a real robot of its size can be off (:func:`prior_sigma`). The estimate is the
maximum a-posteriori (MAP) one, regularised least squares with one pseudo-observation row per
parameter, ``noise * (value - nominal) / sigma`` in the residuals' unit (``noise``: the residual
scale of one measurement row, estimated from the data by :func:`linear_analysis`). A parameter the
data determine moves freely; one they cannot determine stays near nominal instead of wandering
along a null direction. This is seed 003's ridge step with a physical, per-parameter ridge.

The industrial class's scales (1 sigma, :data:`robocal.kinematics.prior_spec.CLASSES`) are deliberately
generous: they are the
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

from dataclasses import dataclass, field

import numpy as np

from robocal.identify.evidence import (
    DIAGNOSIS_WIDENING,
    EVIDENCE_GAIN_NATS,
    MAX_WIDENING,
    WIDENING_RTOL,
    NormalStats,
    fit_group_scales,
)
from robocal.identify.linalg import ScaledSVD
from robocal.identify.robust import MAD_TO_SIGMA
from robocal.identify.space import block_of
from robocal.kinematics.joint_errors import term_of
from robocal.kinematics.prior_spec import CLASSES, DISPLAY_FACTOR, GROUP_UNITS, GROUPS, PriorSpec, class_of

# the group scales of each robot class (zeros, twists, lengths per metre of the arm's summed link
# lengths, a factor on the joint-error scales below): robocal.kinematics.prior_spec.CLASSES
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


def class_defaults(robot) -> tuple[str, str, dict[str, float]]:
    """The robot's prior class (:func:`robocal.kinematics.prior_spec.class_of`), why it was
    chosen, and the class's default scale of each group (SI: rad, m; ``errors`` a factor on
    :data:`JOINT_ERROR_SIGMA`); lengths grow with the arm's summed link lengths."""
    name, why = class_of(robot)
    c = CLASSES[name]
    size_m = float(np.abs(robot.a).sum() + np.abs(robot.d).sum())
    return name, why, {"zeros": np.deg2rad(c.zeros_deg), "twists": np.deg2rad(c.twists_deg),
                       "lengths": max(c.lengths_min_mm, c.lengths_mm_per_m * size_m) * 1e-3,
                       "errors": c.errors}


def group_scales(robot) -> dict[str, float]:
    """The scale of each group (SI) a fit of ``robot`` uses: its class's defaults, overridden by
    the scales a calibration estimated and those the user gave (``robot.priors``)."""
    spec = robot.priors
    defaults = class_defaults(robot)[2]
    return defaults if spec is None else {**defaults, **spec.estimated, **spec.scales}


def stated_sigma(robot, names) -> np.ndarray:
    """:func:`prior_sigma` with the scales the class and the user state, not those a calibration
    estimated from the data (the plausibility limits' measure: a mistake in the data widens those)."""
    spec = robot.priors
    return prior_sigma(robot if spec is None else robot.with_priors(spec.with_estimated({})), names)


def group_of(robot, name: str) -> str | None:
    """The prior group of a parameter (:data:`robocal.kinematics.prior_spec.GROUPS`), None for
    frames, SMR offsets and nuisance (no prior)."""
    block = block_of(name)
    if block == "joint_errors":
        return "errors"
    if block != "links":
        return None
    kind = name.rstrip("0123456789")
    return {"a": "lengths", "d": "lengths", "theta": "zeros"}.get(kind, "twists")


def prior_sigma(robot, names) -> np.ndarray:
    """1-sigma prior scale ``(k,)`` (SI) of each named robot parameter (:func:`group_scales` of
    its group; a joint-error term's :data:`JOINT_ERROR_SIGMA` times the ``errors`` factor);
    ``inf`` for frames and SMR offsets (no prior)."""
    scales = group_scales(robot)
    out = []
    for name in names:
        group = group_of(robot, name)
        if group is None:
            out.append(np.inf)
        elif group == "errors":
            out.append(JOINT_ERROR_SIGMA[term_of(name)] * scales["errors"])
        else:
            out.append(scales[group])
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


_DISPLAY = {g: (GROUP_UNITS[g], DISPLAY_FACTOR[g]) for g in GROUPS}  # (unit, factor from SI)


@dataclass(frozen=True)
class PriorScales:
    """The group scales a fit used and where each came from (``source``: 'fixed' the class default
    kept, 'estimated' widened by the evidence, 'user' given), with the class, why it was chosen,
    the evidence gain (nats) over the defaults, the groups the data pushed to the bound and
    ``asked``: the scales the data ask for when every group may widen up to
    :data:`robocal.identify.evidence.DIAGNOSIS_WIDENING` times what was used (the diagnosis of a
    fit whose priors are too tight), with the linear MAP residual RMS (residual unit) with the
    scales used and with those asked for."""

    robot_class: str
    why: str
    scales: dict
    defaults: dict
    source: dict
    gain: float = 0.0
    at_bound: tuple = ()
    asked: dict = field(default_factory=dict)
    asked_gain: float = 0.0
    rms_used: float = float("nan")
    rms_asked: float = float("nan")

    def display(self, scales: dict) -> dict:
        """``{group: value}`` in the display units (deg, mm, x)."""
        return {g: float(v * _DISPLAY[g][1]) for g, v in scales.items()}

    @property
    def tighter_than_asked(self) -> dict:
        """The groups the data ask to widen (beyond the scale used, by the evidence gain), in SI."""
        return {g: v for g, v in self.asked.items() if v > self.scales[g] * (1 + WIDENING_RTOL)} \
            if self.asked_gain >= EVIDENCE_GAIN_NATS else {}

    def option(self) -> str:
        """The ``--priors`` text that sets the scales the data ask for."""
        wider = self.tighter_than_asked
        return ",".join(f"{g}={wider[g] * _DISPLAY[g][1]:.3g}{_DISPLAY[g][0]}" for g in GROUPS if g in wider)

    def to_dict(self) -> dict:
        """Plain data (display units: deg, mm, x) for the result JSON and the report."""
        return {"class": self.robot_class, "class_chosen_by": self.why,
                "groups": {g: {"scale": self.display({g: v})[g], "unit": _DISPLAY[g][0],
                               "default": self.display({g: self.defaults[g]})[g], "source": self.source[g]}
                           for g, v in self.scales.items()},
                "evidence_gain_nats": self.gain, "at_bound": list(self.at_bound),
                "asked": self.display(self.tighter_than_asked), "asked_gain_nats": self.asked_gain}

    def warnings(self) -> list[str]:
        """A warning per group the data pushed to the widening bound."""
        return [f"the data ask for a {g} prior wider than {MAX_WIDENING:g} times the {self.robot_class} "
                f"class default ({self.display({g: self.scales[g]})[g]:.3g} {_DISPLAY[g][0]}): another "
                "robot's model, a wrong joint convention or a mistake in the data, or a robot of another "
                "class (name it with --priors class=...)" for g in self.at_bound]

    def sentence(self) -> str:
        """One line: the class and each group's scale and source."""
        parts = [f"{g} {self.display({g: v})[g]:.3g} {_DISPLAY[g][0]} ({self.source[g]})"
                 for g, v in self.scales.items()]
        return f"priors of the {self.robot_class} class ({self.why}): " + (
            ", ".join(parts) or "no estimated parameter has a prior (frames only)")


def fit_priors(robot, J: np.ndarray, r: np.ndarray, names, noise: float) -> tuple[object, PriorScales]:
    """``robot`` with the group scales the data ask for (empirical Bayes,
    :func:`robocal.identify.evidence.fit_group_scales`) recorded in its priors, and the record:
    ``J (M, k)`` the weighted Jacobian of the unknowns ``names`` at the registered nominal model,
    ``r (M,)`` its residuals, ``noise`` the robust residual scale. Groups the user fixed
    (``robot.priors``) and every group with ``estimate: no`` keep their scale."""
    spec = robot.priors or PriorSpec()
    robot_class, why, defaults = class_defaults(robot)
    used = group_scales(robot.with_priors(spec.with_estimated({})))
    groups = [group_of(robot, n) for n in names]
    present = [g for g in GROUPS if g in groups]
    estimated = [g for g in present if g not in spec.scales] if spec.estimate else []
    sigma = prior_sigma(robot.with_priors(spec.with_estimated({})), names)
    stats = NormalStats.of(J, r)
    fit = fit_group_scales(J, r, sigma, groups, estimated, noise, stats=stats)
    widened = {g: used[g] * f for g, f in fit.factors.items() if f > 1.0}
    scales = {g: widened.get(g, used[g]) for g in present}
    source = {g: "user" if g in spec.scales else "estimated" if g in widened else "fixed" for g in present}
    fitted = robot.with_priors(spec.with_estimated(widened))
    asked = fit_group_scales(J, r, prior_sigma(fitted, names), groups, present, noise,
                             max_widening=DIAGNOSIS_WIDENING, stats=stats)
    record = PriorScales(robot_class, why, scales, {g: defaults[g] for g in present}, source, fit.gain,
                         fit.at_bound, {g: scales[g] * f for g, f in asked.factors.items()}, asked.gain,
                         asked.rms_default, asked.rms_fitted)
    return fitted, record
