"""Accuracy over the workspace: where does a calibration hold?

The predicted TCP position error of a calibrated model at joints ``q`` is

    e(q) = sqrt( trace( G(q) C G(q)^T ) + u^2 )

with ``G(q) (3, k)`` the identification Jacobian of the TCP point over the robot parameters,
``C`` their posterior covariance and ``u`` the unmodelled error (3-D RMS). ``C`` is the MAP
posterior of *every* candidate parameter of the calibration (not only the estimated ones): the
data's information ``J^T J / s0^2`` (``s0`` the a-posteriori residual scale) plus each
parameter's prior precision ``1 / sigma_prior^2`` (:func:`robocal.identify.priors.prior_sigma`;
frames have none). A parameter the data do not determine keeps its prior's uncertainty, which is
what a model learnt from clustered poses carries elsewhere. ``u`` is the cross-validated error of
the chosen error model when the calibration chose one (``nongeometric="auto"``), else the
calibration residual's RMS corrected for the degrees of freedom (``sqrt(sum |e|^2 / (n - k/3))``);
it includes the tracker noise, as the validation figures do.

``u`` is measured over the joint ranges the calibration poses span, ``[lo_j, hi_j]``; beyond them
the error a model lacks (gear harmonics, compliance, any smooth function of the joints) is
extrapolated with no data. The prediction grows it there (the coverage penalty):
``u(q) = u (1 + g sum_j x_j(q))``, ``x_j = max(lo_j - q_j, q_j - hi_j, 0) / w_j`` the excursion in
sampled widths ``w_j = max(hi_j - lo_j, f (limit range_j))`` (``g`` :data:`EXTRAPOLATION_GROWTH`,
``f`` :data:`SAMPLED_WIDTH_FLOOR`): linear, the first-order growth of an error fitted by a smooth
model over a range and used beyond it. Inside the sampled ranges (every pose of a campaign over the
full ranges, nearly) nothing changes. Measured on arms with gear errors calibrated geometrically on
poses in the upper half of each joint's range (four families, two seeds each): predicted workspace
RMS 0.62-0.89 mm against true 0.27-1.09 mm, where the prediction without growth said 0.24-0.37.
When the growth raises the workspace RMS by :data:`EXTRAPOLATED_SHARE` or more, the section's
``extrapolated`` entry (and the summary line) names the joints that leave their ranges most; by
:data:`EXTRAPOLATED_WARN` times or more, a warning does (unless the "holds only near its poses"
warning already names them).

Two regions are reported: the robot's workspace, :data:`WORKSPACE_SAMPLES` joint vectors uniform
within the joint limits (seed :data:`WORKSPACE_SEED`, the model's tool), and the calibration
poses themselves. When the workspace RMS exceeds :data:`EXTRAPOLATION_FACTOR` times the
validated error (the validation RMS, else ``u``), the calibration holds only near its poses: the
warning names the joints whose calibration poses span less than :data:`COVERAGE_MIN_FRACTION` of
their range. :meth:`Prediction.error_mm` is the per-target API (``compensate --result``).

Data measured in no frame of the robot's world (plane and flush contacts, distances) promise
accuracy only up to a rigid motion of the world, and without a length reference up to scale: their
prediction is the error left after that motion (:mod:`robocal.trust.gauge`), the line says so, and
the scale's prior is reported apart.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from robocal.core.errors import DataError
from robocal.identify.identifiability import Identifiability
from robocal.identify.priors import prior_sigma
from robocal.identify.problem import CalibrationProblem
from robocal.identify.solvers import SolverResult
from robocal.identify.space import ParameterSpace, State, block_of
from robocal.kinematics.model import Robot
from robocal.trust.gauge import gauge_free, gauge_of, scale_section

WORKSPACE_SAMPLES = 1000  # joint vectors of the workspace sample
WORKSPACE_SEED = 0  # its seed: the same model gives the same figures
EXTRAPOLATION_FACTOR = 3.0  # workspace RMS beyond this x the validated error: holds only near its poses
COVERAGE_MIN_FRACTION = 0.5  # a joint whose calibration poses span less of its range is not covered
DISTANCE_BINS = 8  # bins of the predicted error against the joint distance to the calibration poses
# The unmodelled error is measured over the joint ranges the calibration poses span: beyond them a
# smooth joint-space error the model lacks (gear harmonics, compliance) is extrapolated with no data.
# It grows by this many times u per sampled width a joint leaves its range by (module docstring)
EXTRAPOLATION_GROWTH = 1.0
SAMPLED_WIDTH_FLOOR = 0.1  # a joint's sampled width counts as at least this fraction of its limits
EXTRAPOLATED_SHARE = 0.1  # the workspace RMS grows by this share or more: the section names the joints
# ... and by this factor or more: a warning. Measured: the real Meca500 and IRB 120 sets (q1 on 30 %,
# q6 on 42 % of their ranges) grow 1.42 and 1.21 x; geared arms on the upper half of every joint's
# range (five families) 2.2-2.6 x
EXTRAPOLATED_WARN = 1.75
# the keys of robocal.trust.gauge.scale_section
SCALE_KEYS = ("reference", "nominal_mm", "prior_mm", "relative", "workspace_rms_mm", "text")


@dataclass(frozen=True)
class Prediction:
    """What predicts the TCP error anywhere: the robot parameters ``names`` and their posterior
    covariance ``(k, k)`` (SI), the unmodelled error ``unmodelled_mm`` (3-D RMS) and the validated
    error ``validated_mm`` it is compared with (and where that figure comes from); for data without
    a world frame the ``gauge`` the errors are up to (``'up to a rigid motion of the world and
    scale (why)'``) and the ``scale`` its prior leaves (:func:`robocal.trust.gauge.scale_section`)."""

    names: tuple[str, ...]
    covariance: np.ndarray
    unmodelled_mm: float
    validated_mm: float
    validated_from: str
    gauge: str = ""
    scale: dict | None = None
    sampled: np.ndarray | None = None  # (n, 2) joint ranges the calibration poses span (rad; m)

    def outside(self, robot, q: np.ndarray) -> np.ndarray:
        """``(N, n)``: how far each joint of ``q (N, n)`` leaves its sampled range, in sampled widths
        (at least :data:`SAMPLED_WIDTH_FLOOR` of the joint's limits); 0 inside it or without sampled
        ranges (a result JSON of an earlier version)."""
        if self.sampled is None:
            return np.zeros(np.shape(q))
        if self.sampled.shape != (robot.n_joints, 2):
            raise DataError(f"the prediction's sampled joint ranges are of {len(self.sampled)} joints, model "
                            f"{robot.name} has {robot.n_joints}: use the result JSON written with this model")
        lo, hi = self.sampled[:, 0], self.sampled[:, 1]
        width = np.maximum(hi - lo, SAMPLED_WIDTH_FLOOR * (robot.limits[:, 1] - robot.limits[:, 0]))
        return np.maximum(np.maximum(lo - q, q - hi), 0.0) / np.maximum(width, 1e-12)

    def error_mm(self, robot, q) -> np.ndarray:
        """Predicted RMS TCP position error ``(N,)`` (mm) of ``robot`` (the calibrated model) at
        joints ``q (N, n)`` (rad): the parameters' posterior propagated, and the unmodelled error
        grown where the joints leave the sampled ranges (module docstring)."""
        return self.errors_mm(robot, q)[0]

    def errors_mm(self, robot, q) -> tuple[np.ndarray, np.ndarray]:
        """``(error_mm, within_mm)``, each ``(N,)`` (mm): `error_mm`, and the same without the
        growth beyond the sampled ranges; the Jacobians are computed once for both."""
        q = robot.check_joints(q)
        missing = [n for n in self.names if n not in robot.parameter_names]
        if missing:
            raise DataError(f"the prediction's parameters {missing[:4]} are not in model {robot.name}: "
                            "use the result JSON written with this calibrated model")
        G = tcp_jacobian(robot, self.names, q)  # (N, 3, k)
        var = np.einsum("nik,nik->n", G @ self.covariance, G)  # G C G^T's trace, pose by pose
        var = np.maximum(var, 0.0)
        u = self.unmodelled_mm * 1e-3 * (1.0 + EXTRAPOLATION_GROWTH * self.outside(robot, q).sum(axis=1))
        return np.sqrt(var + u**2) * 1e3, np.sqrt(var + (self.unmodelled_mm * 1e-3) ** 2) * 1e3

    def beyond(self, robot, q) -> np.ndarray:
        """``(N,)`` bool: targets where the predicted error exceeds :data:`EXTRAPOLATION_FACTOR`
        times the validated error."""
        return self.error_mm(robot, q) > EXTRAPOLATION_FACTOR * self.validated_mm

    def to_dict(self) -> dict:
        return {"names": list(self.names), "covariance_si": self.covariance.tolist(),
                "unmodelled_mm": self.unmodelled_mm, "validated_mm": self.validated_mm,
                "validated_from": self.validated_from, "gauge": self.gauge, "scale": self.scale,
                "sampled_si": None if self.sampled is None else self.sampled.tolist()}

    @classmethod
    def from_dict(cls, d: dict) -> Prediction:
        """From :meth:`to_dict` (a result JSON's ``predicted_accuracy.model``); DataError if malformed."""
        try:
            names = tuple(str(n) for n in d["names"])
            cov = np.asarray(d["covariance_si"], dtype=float).reshape(len(names), len(names))
            scale, sampled = d.get("scale"), d.get("sampled_si")
            out = cls(names, cov, float(d["unmodelled_mm"]), float(d["validated_mm"]),
                      str(d["validated_from"]), str(d.get("gauge") or ""),
                      None if scale is None else {k: scale[k] for k in SCALE_KEYS},
                      None if sampled is None else np.asarray(sampled, dtype=float).reshape(-1, 2))
        except (KeyError, TypeError, ValueError) as exc:
            raise DataError(f"the result's predicted_accuracy.model is malformed ({exc}): use a result "
                            "JSON written by robocal calibrate") from None
        bad_sampled = out.sampled is not None and not (
            np.isfinite(out.sampled).all() and (out.sampled[:, 1] >= out.sampled[:, 0]).all())
        if not np.isfinite(cov).all() or out.unmodelled_mm < 0 or not out.validated_mm > 0 or bad_sampled:
            raise DataError("the result's predicted_accuracy.model has non-finite or negative figures")
        return out


def tcp_jacobian(robot, names, q: np.ndarray) -> np.ndarray:
    """``G(q) (N, 3, k)``: the TCP position's identification Jacobian (m per SI unit) over the
    robot parameters ``names`` at joints ``q (N, n)`` (rad), through which a parameter
    covariance becomes a predicted TCP error."""
    return robot.jacobian(q, list(names), kind="point")


def region_matrix(robot, names, q: np.ndarray) -> np.ndarray:
    """``A (k, k)``: the mean of ``G(q)^T G(q)`` (:func:`tcp_jacobian`) over the joints
    ``q (R, n)``, so that ``trace(C A)`` is the mean over ``q`` of the predicted TCP variance
    (m^2, before the unmodelled error) of :meth:`Prediction.error_mm` for the covariance ``C``:
    the I-optimality criterion the campaign planner minimises over the workspace sample."""
    G = tcp_jacobian(robot, names, q)
    return np.einsum("rik,ril->kl", G, G) / len(q)


GRAM_RCOND = 1e-12  # eigenvalues of the scaled information below this (relative) carry no information


def information_covariance(J: np.ndarray, weight: np.ndarray, s0: float) -> np.ndarray:
    """``s0^2 (J^T J + diag(weight^2))^-1`` ``(k, k)`` through the scaled ``(k, k)`` information
    matrix (the posterior of :func:`robocal.identify.priors.posterior_covariance` without an SVD of
    the tall ``J (M, k)``: a calibration's thousands of rows cost one product), pseudo-inverse on
    the directions neither the data nor a prior determine."""
    scale = np.sqrt(np.sum(J**2, axis=0) + weight**2)
    scale = np.where(scale > 0, scale, 1.0)
    Js = J / scale
    info = Js.T @ Js + np.diag((weight / scale) ** 2)
    w, V = np.linalg.eigh(info)
    keep = w > GRAM_RCOND * max(w.max(initial=0.0), 1e-300)
    inv = (V[:, keep] / w[keep]) @ V[:, keep].T
    return s0**2 * inv / np.outer(scale, scale)


def posterior(problem, state, names: list[str], s0: float) -> np.ndarray:
    """The MAP posterior covariance ``(k, k)`` (SI) of the robot parameters ``names`` from the
    problem's information at ``state`` (nuisance marginalised) and the parameters' priors, with
    the residual scale ``s0`` (the problem's residual unit)."""
    space = problem.space(state.robot, names)
    J = problem.jacobian(state, space)
    sigma = np.r_[prior_sigma(state.robot, space.robot), np.full(len(space.nuisance), np.inf)]
    cov = information_covariance(J, np.where(np.isfinite(sigma), s0 / sigma, 0.0), s0)
    k = len(space.robot)
    return cov[:k, :k]


class Fit(Protocol):
    """What :func:`prediction` reads of a fit: a calibration result
    (:class:`robocal.calibration.result.CalibrationResult`) has it all. Named here so that the
    trust layer states what it needs without importing the calibration above it."""

    problem: CalibrationProblem
    state: State
    robot: Robot
    space: ParameterSpace
    identifiability: Identifiability
    solver: SolverResult
    model_selection: dict | None
    validation: dict | None
    judged: list


def _absorbed(result: Fit) -> set[str]:
    """Robot parameters held at nominal because an instrument's own frame (a camera's, a capture
    system's: observations with ``frames_replace_base``) moves the TCP exactly as they do: their
    error is a rigid motion of the robot's world that frame takes, as the base frame takes it for a
    tracker, so they predict no error in the instrument's frame."""
    frames = {n for obs in result.problem.observations if getattr(obs, "frames_replace_base", False)
              for n in obs.nuisance_names}
    ident = result.identifiability
    return {n for n in ident.dropped if ident.confounded_with.get(n)
            and set(ident.confounded_with[n]) <= frames}


def prediction(result: Fit) -> Prediction:
    """The :class:`Prediction` of a fit (a calibration result): the posterior of its candidate robot
    parameters the calibrated model carries (extra SMR offsets marginalised), ``u`` from its
    cross-validation or its dof-corrected residual, the validated error from its validation data
    when there are any."""
    problem, state, robot = result.problem, result.state, result.robot
    nuisance = set(problem.nuisance_names)
    # a frame parameter the data cannot identify has no prior either: held at nominal, it carries no
    # variance (its column may be round-off only: a scale bar's SMR height on a SCARA, 1e-12 of the
    # others, which the scaled information would read as information on a 1 m scale)
    held = {n for n in result.identifiability.dropped if block_of(n) != "links"} | _absorbed(result)
    names = [n for n in result.identifiability.names
             if n not in nuisance and n in robot.parameter_names and n not in held]
    r = problem.residuals(state)
    s0 = float(np.sqrt(r @ r / max(r.size - result.space.size, 1)))
    errors = problem.item_error_vectors(state)
    weights = result.solver.item_weights
    rejected = weights is not None and bool((weights == 0).any())
    if rejected:  # a robust fit's rejected observations are outliers, not the model's error
        inlier = np.asarray(weights) != 0
        kept = [e[inlier[b]] for e, b in zip(errors, problem.item_blocks(), strict=True)]
        mean_sq = [sum(float(np.sum(e**2)) for e in es) / max(sum(e.size for e in es), 1)
                   for es in (errors, kept)]
        s0 *= float(np.sqrt(mean_sq[1] / mean_sq[0])) if mean_sq[0] > 0 else 1.0
        errors = kept
    cov = posterior(problem, state, names, s0)
    keep = [i for i, n in enumerate(names) if not n.startswith("smr")]
    comps = sum(e.size for e in errors)
    u = float(np.sqrt(3 * sum(float(np.sum(e**2)) for e in errors) / max(comps - result.space.size, 1))) * 1e3
    source = "calibration residual (dof-corrected" + (", rejected left out)" if rejected else ")")
    ms = result.model_selection
    if ms is not None and not rejected:  # the cross-validation's folds hold the outliers too
        u, source = float(ms["candidates"][ms["chosen"]]["cv_rms_mm"]), "cross-validated"
    validated, vsource = (result.validation["rms"], "on the validation data") if result.judged \
        else (u, source)
    names, cov = [names[i] for i in keep], cov[np.ix_(keep, keep)]
    q_cal = np.vstack([d.joints for d in problem.datasets])
    sampled = np.column_stack([q_cal.min(axis=0), q_cal.max(axis=0)])
    gauge = gauge_of(problem.observations, robot)
    if gauge is None:
        return Prediction(tuple(names), cov, u, max(validated, 1e-6), vsource, sampled=sampled)
    q_ws = workspace_sample(robot)
    names, cov = gauge_free(robot, names, cov, gauge, q_ws)
    return Prediction(tuple(names), cov, u, max(validated, 1e-6), vsource,
                      f"{gauge.text} ({gauge.why})", scale_section(robot, gauge, q_ws), sampled)


def accuracy_line(section: dict) -> str:
    """The one-line summary of a ``predicted_accuracy`` section."""
    ws, cal = section["workspace"], section["calibration_region"]
    gauge, scale = section.get("gauge"), section.get("scale")
    return (f"predicted accuracy{' ' + gauge if gauge else ''}: {ws['rms']:.4f} mm RMS (p95 "
            f"{ws['p95']:.4f}) over the workspace, {cal['rms']:.4f} mm RMS at the calibration poses; "
            f"validated {section['validated_mm']:.4f} mm ({section['validated_from']})"
            + (f"; {scale['text']}" if scale else "") + _extrapolated_text(section.get("extrapolated")))


def _extrapolated_text(entry: dict | None) -> str:
    """The accuracy line's clause on an ``extrapolated`` entry ('' without one)."""
    if not entry:
        return ""
    return (f"; extrapolated beyond the joint ranges the calibration sampled ({entry['text']}): "
            f"{entry['rms_within_mm']:.4f} mm RMS without growing the unmodelled error there")


def workspace_sample(robot, n: int = WORKSPACE_SAMPLES, seed: int = WORKSPACE_SEED) -> np.ndarray:
    """``(n, dof)`` joint vectors uniform within ``robot``'s joint limits (rad), seeded."""
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    return np.random.default_rng(seed).uniform(lo, hi, (n, robot.n_joints))


def _stats(e: np.ndarray) -> dict:
    return {"n": int(e.size), "rms": float(np.sqrt(np.mean(e**2))), "p95": float(np.percentile(e, 95)),
            "max": float(e.max())}


def joint_coverage(robot, q_cal: np.ndarray) -> list[dict]:
    """Per joint (``joint``: its 1-based number in the joint vector, `Robot.joints` names it): its
    limits and the range the calibration poses ``q_cal (N, n)`` (rad; m) span, in the joint's unit
    (``limits_deg``, ``covered_deg``; a prismatic joint's ``limits_mm``, ``covered_mm``), and the
    fraction of the limits that is."""
    lo, hi = robot.joints_shown(robot.limits.T)
    a, b = robot.joints_shown(q_cal.min(axis=0)), robot.joints_shown(q_cal.max(axis=0))
    return [{"joint": j + 1, f"limits_{spec.unit}": [float(lo[j]), float(hi[j])],
             f"covered_{spec.unit}": [float(a[j]), float(b[j])],
             "fraction": float(min(1.0, (b[j] - a[j]) / max(hi[j] - lo[j], 1e-12)))}
            for j, spec in enumerate(robot.joints)]


def covered_text(robot, entry: dict) -> str:
    """One joint of `joint_coverage` in words: ``q2 (covered -40..60 of -95..155 deg)``, a quill's ``q3
    (covered -50..0 of -200..0 mm)``."""
    spec = robot.joints[entry["joint"] - 1]
    (a, b), (lo, hi) = entry[f"covered_{spec.unit}"], entry[f"limits_{spec.unit}"]
    return f"{spec.name} (covered {a:.0f}..{b:.0f} of {lo:.0f}..{hi:.0f} {spec.unit})"


def _by_distance(robot, q_ws: np.ndarray, q_cal: np.ndarray, err: np.ndarray) -> dict:
    """The workspace sample's predicted error binned by its joint-space distance (Euclidean over
    the joints in their units: deg, a prismatic joint's mm counting as deg) to the nearest
    calibration pose: bin centres and the RMS per bin."""
    from scipy.spatial import cKDTree

    dist = (cKDTree(robot.joints_shown(q_cal)).query(robot.joints_shown(q_ws))[0] if robot.has_prismatic
            else np.rad2deg(cKDTree(q_cal).query(q_ws)[0]))
    edges = np.quantile(dist, np.linspace(0, 1, DISTANCE_BINS + 1))
    idx = np.clip(np.searchsorted(edges, dist, side="right") - 1, 0, DISTANCE_BINS - 1)
    centres, rms = [], []
    for b in range(DISTANCE_BINS):
        sel = idx == b
        if sel.any():
            centres.append(float(np.mean(dist[sel])))
            rms.append(float(np.sqrt(np.mean(err[sel] ** 2))))
    return {"distance_deg": centres, "rms_mm": rms}


def _extrapolated(robot, prediction: Prediction, q_ws: np.ndarray, ws: np.ndarray, within: np.ndarray,
                  joints: list[dict]) -> dict | None:
    """The ``extrapolated`` entry of the section when the unmodelled error's growth beyond the
    sampled joint ranges raises the workspace RMS by :data:`EXTRAPOLATED_SHARE` or more: the RMS
    within the ranges (no growth), the growth factor and the joints that carry at least that share
    of the excursions, with their ranges (`covered_text`); None otherwise. ``ws``, ``within``: the
    workspace sample's predicted error with and without that growth (`Prediction.errors_mm`)."""
    rms, rms_within = (float(np.sqrt(np.mean(e**2))) for e in (ws, within))
    if rms < (1.0 + EXTRAPOLATED_SHARE) * rms_within:
        return None
    excursion = prediction.outside(robot, q_ws).mean(axis=0)
    named = [j for j in joints if excursion[j["joint"] - 1] >= EXTRAPOLATED_SHARE * excursion.sum()]
    return {"rms_within_mm": rms_within, "growth": EXTRAPOLATION_GROWTH,
            "joints": [j["joint"] for j in named], "text": ", ".join(covered_text(robot, j) for j in named)}


def predict(robot, prediction: Prediction, q_cal: np.ndarray) -> tuple[dict, list[str]]:
    """The ``predicted_accuracy`` section (module docstring) of a calibrated ``robot`` with its
    ``prediction`` and calibration joints ``q_cal (N, n)`` (rad), and its warnings."""
    q_ws = workspace_sample(robot)
    (ws, within), cal = prediction.errors_mm(robot, q_ws), prediction.error_mm(robot, q_cal)
    joints = joint_coverage(robot, q_cal)
    ratio = float(np.sqrt(np.mean(ws**2))) / prediction.validated_mm
    out = {"workspace": {**_stats(ws), "samples": WORKSPACE_SAMPLES, "seed": WORKSPACE_SEED,
                         "sampling": "uniform within the joint limits, the model's tool"},
           "calibration_region": {**_stats(cal), "sampling": "the calibration poses"},
           "validated_mm": prediction.validated_mm, "validated_from": prediction.validated_from,
           "unmodelled_mm": prediction.unmodelled_mm, "ratio": ratio, "factor": EXTRAPOLATION_FACTOR,
           "holds_only_near_poses": ratio > EXTRAPOLATION_FACTOR, "coverage": joints,
           "by_distance": _by_distance(robot, q_ws, q_cal, ws), "model": prediction.to_dict()}
    if prediction.gauge:
        out.update(gauge=prediction.gauge, scale=prediction.scale)
    if (extrapolated := _extrapolated(robot, prediction, q_ws, ws, within, joints)) is not None:
        out["extrapolated"] = extrapolated
    warnings = []
    if out["holds_only_near_poses"]:
        narrow = [j for j in joints if j["fraction"] < COVERAGE_MIN_FRACTION]
        where = ("; measure poses over the rest of " + ", ".join(
            covered_text(robot, j) for j in narrow)) if narrow else \
            "; measure poses spread over the workspace"
        ws_rms, ws_p95 = out["workspace"]["rms"], out["workspace"]["p95"]
        up_to = f" {prediction.gauge}" if prediction.gauge else ""
        warnings.append(f"the calibration holds only near its poses: predicted{up_to} {ws_rms:.3g} mm RMS "
                        f"(p95 {ws_p95:.3g}) over the workspace against {prediction.validated_mm:.3g} mm "
                        f"{prediction.validated_from} ({ratio:.3g} x, beyond {EXTRAPOLATION_FACTOR:g} x)"
                        + where)
    elif extrapolated and out["workspace"]["rms"] >= EXTRAPOLATED_WARN * extrapolated["rms_within_mm"]:
        ws_rms, ws_p95 = out["workspace"]["rms"], out["workspace"]["p95"]
        within = extrapolated["rms_within_mm"]
        warnings.append(f"the workspace prediction is extrapolated: {ws_rms:.3g} mm RMS (p95 {ws_p95:.3g}) "
                        f"over the workspace, {within:.3g} within the joint ranges the calibration sampled; "
                        "its unmodelled error is unknown beyond them: measure poses over the rest of "
                        f"{extrapolated['text']}")
    return out, warnings


_LISTED = 10  # targets named in a per-target warning


def target_warnings(prediction: Prediction, robot, q: np.ndarray, what: str = "target") -> list[str]:
    """The warning (a list of at most one line) for the joint vectors ``q (N, n)`` (rad) of targets
    where ``robot``'s predicted error exceeds :data:`EXTRAPOLATION_FACTOR` times the validated
    one: their 1-based numbers and predicted errors (mm)."""
    q = np.asarray(q, dtype=float)
    ok = np.isfinite(q).all(axis=1)
    err = np.full(len(q), np.nan)
    err[ok] = prediction.error_mm(robot, q[ok])
    bad = np.flatnonzero(err > EXTRAPOLATION_FACTOR * prediction.validated_mm)
    if not bad.size:
        return []
    named = ", ".join(f"{i + 1} ({err[i]:.3g} mm)" for i in bad[:_LISTED])
    more = f" and {bad.size - _LISTED} more" if bad.size > _LISTED else ""
    return [f"{bad.size} of {len(q)} {what}s lie where the calibration's predicted error exceeds "
            f"{EXTRAPOLATION_FACTOR:g} x the validated {prediction.validated_mm:.3g} mm "
            f"({prediction.validated_from}): {what}s {named}{more}; measure poses near them and recalibrate"]
