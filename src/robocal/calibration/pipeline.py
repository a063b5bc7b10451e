"""``rc.calibrate``: registration, identifiability, a solver, uncertainty and statistics.

The pipeline: fit the tracker frame and SMR offsets to the nominal model (registration), declare
the joint-error terms asked for, pick the identifiable parameters (QR with pivoting: the
`ParameterSpace` that is estimated), run the chosen method, then compute the covariance of
the estimate and the before/after position statistics. Which joint-error terms: named by the
user, or chosen by cross-validation (`robocal.calibration.model_selection`, ``nongeometric='auto'``,
the default on tracker data of enough poses), with cyclic frequencies searched in the data
(`robocal.identify.frequency_search`).
"""

from __future__ import annotations

import datetime
from dataclasses import replace
from functools import partial

import numpy as np

from robocal.calibration.cell import calibrate_cell
from robocal.calibration.model_selection import calibrate_cyclic, select_error_model
from robocal.calibration.result import CalibrationResult, Judged
from robocal.core.damped_least_squares import Status
from robocal.core.errors import DataError, IdentificationError, PlausibilityError
from robocal.core.progress import Progress
from robocal.core.resources import calibration_bytes, check_memory, few_threads, memory_guard
from robocal.core.version import __version__
from robocal.data.instruments import declared, default_method, instrument_of
from robocal.data.kinds import kind_spec
from robocal.data.measurements import Measurements
from robocal.data.registration import register
from robocal.identify.identifiability import DEFAULT_RTOL, Identifiability, hold
from robocal.identify.identifiability import analyze as analyze_jacobian
from robocal.identify.plausibility import (
    GROSS_FRACTION,
    bulk_rms_mm,
    check_corrections,
    check_joint_limits,
    check_residual,
    check_spread,
)
from robocal.identify.priors import (
    PriorScales,
    fit_priors,
    linear_analysis,
    prior_sigma,
    stated_sigma,
    undetermined,
)
from robocal.identify.problem import CalibrationProblem
from robocal.identify.robust import GROSS_K1, without_gross_errors
from robocal.identify.solvers import SolverResult, check_options, get_solver, iteration_limit
from robocal.identify.space import ParameterSpace, State, block_of
from robocal.identify.structural import separate, structural_form, unidentifiable
from robocal.identify.uncertainty import correlation, covariance
from robocal.identify.variance_components import chosen as chosen_components
from robocal.identify.variance_components import fit as fit_components
from robocal.kinematics.conditions import range_of as conditions_range
from robocal.kinematics.joint_errors import TERMS, candidate_names, parse_terms, term_of
from robocal.kinematics.prior_spec import PriorSpec
from robocal.kinematics.thermal import reference_of as thermal_reference
from robocal.kinematics.workcell import Cell
from robocal.report.metrics import position_stats
from robocal.trust.consistency import check_fit, check_not_worse
from robocal.trust.coverage import predict, prediction
from robocal.trust.diagnosis import diagnosed
from robocal.trust.held_out import HeldOutError, judge_held_out, refused_validation, worse_than_start
from robocal.trust.posterior import Noise, posterior_analysis
from robocal.trust.provenance import JOINT_REPEAT_TOL_DEG, fingerprint, independent, tolerance_unit

NONGEOMETRIC_METHODS = ("lsq", "robust")  # the methods that estimate the joint-error terms
BULK_PERCENT = round(100 * (1 - GROSS_FRACTION))  # the share of measurements the misfit checks judge
AUTO_DEFAULT_KINDS = ("point", "pose")  # tracker data: where nongeometric="auto" is the default ...
# ... from this many poses on (6 held out per cross-validation fold): measured on real sets of 31-41
# poses (a humanoid's arm, an IRB 120 campaign), where the chosen terms beat the geometric model held
# out (TALOS 0.761 -> 0.617 mm, IRB 120 test points 0.321 -> 0.163 mm mean), and the one-standard-error
# rule keeps the geometric model where they do not (TIAGo next day)
AUTO_DEFAULT_MIN_POSES = 30


def _start_model(robot, datasets: list, register_frames: bool, force: bool, warnings: list[str]):
    """The nominal model with the tracker frame and SMR offsets fitted to the first point or pose
    set; the measured points must spread like the fitted model's (a unit or robot mix-up else)."""
    data = next((d for d in datasets if d.spec.sees_position), None)
    if data is None or not register_frames:
        return robot
    start = register(robot, data)
    check_spread(data.points, start.fk(data.joints, smr=data.smr)[:, :3, 3], "the calibration data",
                 force=force, warnings=warnings)
    return start


PROBE_KINDS = ("plane", "distance")  # contact data whose probe tip (the model's tool) no frame fit places
PROBE_PARAMS = ("tool.x", "tool.y", "tool.z")


def _probe_fitted(problem: CalibrationProblem, state0: State, seed: int) -> State:
    """``state0`` with the probe tip (the tool's translation) fitted, when every set is contact data
    (:data:`PROBE_KINDS`): as the SMR offsets are for tracker points, the "frames fitted" of the
    nominal model's plausibility check (a probe 100 mm off the flange otherwise misses planes by
    tens of mm, refused as implausible); unchanged for other data."""
    if not all(d.kind in PROBE_KINDS for d in problem.datasets):
        return state0
    space = problem.space(state0.robot, list(PROBE_PARAMS))
    out = get_solver("lsq")(problem, state0, space, seed=seed)
    return out.state if out.success else state0


def _estimated_space(problem: CalibrationProblem, state0: State, params, rtol: float,
                     n_poses: int) -> tuple[ParameterSpace, Identifiability, list[str], object, PriorScales]:
    """The identifiable unknowns of ``params`` (plus every nuisance parameter), their analysis,
    warnings, the start robot with the prior group scales the data ask for and their record
    (:func:`robocal.identify.priors.fit_priors`); IdentificationError when the data cannot support
    a calibration."""
    candidates = problem.space(state0.robot, params)
    # judged on the chain's structural form: a SCARA microradians off parallel is ranked as the SCARA it is
    J0 = problem.jacobian(replace(state0, robot=structural_form(state0.robot)), candidates)
    ident = analyze_jacobian(J0, candidates.names, n_poses, rtol)
    warnings = []
    if len(problem.observations) == 1:
        problem.observation.check_enough(candidates.size)
    blind = set.intersection(*(set(obs.not_observable(state0.robot)) for obs in problem.observations))
    if blind and isinstance(params, str):
        reason = "; ".join(dict.fromkeys(obs.blind_spot for obs in problem.observations if obs.blind_spot))
        warnings.append(f"{reason}: {', '.join(sorted(blind, key=state0.robot.parameter_names.index))} "
                        "are held at their nominal values")
    n_smr = min(max(d.n_smr for d in problem.datasets), len(state0.robot.smr) + 1)
    structural = unidentifiable(state0.robot, problem.kind, list(candidates.robot), n_smr, rtol)
    possible = candidates.size - (len(structural) if structural != set(candidates.robot) else 0)
    if ident.rank < max(1, possible // 2):  # of what any pose set could identify (a SCARA's freedoms aside)
        raise IdentificationError(
            f"the pose set is degenerate: only {ident.rank} of the {possible} parameters poses spread over "
            f"the joint limits identify are identifiable from {n_poses} poses; measure poses spread over "
            "the workspace")
    if J0.shape[0] <= ident.rank:
        raise IdentificationError(f"{J0.shape[0]} residuals cannot determine {ident.rank} identifiable "
                                  "parameters: measure more poses")
    lost = sorted(set(candidates.nuisance) - set(ident.kept))
    if lost:
        raise IdentificationError(f"the nuisance parameters {lost} are not identifiable: "
                                  "each plane needs contacts spread over its surface")
    kept = candidates.restricted(ident.kept)
    columns = [candidates.names.index(n) for n in kept.names]
    r0, blocks = problem.residuals(state0), [rows for rows, _ in problem.row_blocks()]
    flat = np.full(len(kept.nuisance), np.inf)
    sigma = np.r_[prior_sigma(state0.robot, kept.robot), flat]
    lin = linear_analysis(J0[:, columns], r0, sigma, problem.noise_guess, blocks)
    robot, scales = fit_priors(state0.robot, J0[:, columns], r0, kept.names, lin.noise)
    if "estimated" in scales.source.values():  # widened: the noise weighed against the new priors
        sigma = np.r_[prior_sigma(robot, kept.robot), flat]
        lin = linear_analysis(J0[:, columns], r0, sigma, lin.noise, blocks)
    mean = np.r_[robot.values[robot.indices(kept.robot)], state0.nuisance]
    held, ratio = undetermined(J0[:, columns], sigma, lin.noise)
    ident = hold(ident, J0, [kept.names[j] for j in held],
                 {n: float(q) for n, q in zip(kept.names, ratio, strict=True) if np.isfinite(q)})
    ident = separate(ident, structural, robot)
    warnings += scales.warnings()
    return kept.with_prior(sigma, mean, lin.noise).restricted(ident.kept), ident, warnings, robot, scales


def _run_solver(method: str, problem, state0: State, space: ParameterSpace, seed: int, progress,
                options: dict) -> SolverResult:
    """The method's solve, with a progress bar on a terminal when ``progress`` is True."""
    solve = get_solver(method)
    with Progress(iteration_limit(method, options), f"calibrate ({method})",
                  quiet=progress is not True) as bar:
        if progress is True:
            def progress(iteration, rms):  # noqa: E306 - the bar's callback
                bar.update(info=f"rms {rms * 1e3:.4f} mm")
        out = solve(problem, state0, space, seed=seed, progress=progress or None, **options)
        return without_gross_errors(problem, out, space, progress or None) if method == "lsq" else out


def _gross_warning(weights: np.ndarray) -> str:
    """What least squares did with the gross errors whose ``weights`` (per item) it lowered."""
    rejected, lowered = int(np.sum(weights == 0)), int(np.sum((weights > 0) & (weights < 1)))
    return (f"{rejected} measurement(s) rejected as gross errors (beyond {GROSS_K1:g} robust sigmas of "
            f"their file: a mislabelled marker, a wrong row) and {lowered} down-weighted; they are listed "
            "under 'rejected' in the result JSON. Check them; --method robust weighs every measurement "
            "by its residual")


def _covariance(problem: CalibrationProblem, out: SolverResult, space: ParameterSpace) -> np.ndarray:
    """The posterior covariance s0^2 (J^T W J + P)^-1 at the solution (P: the prior rows' weights
    squared, `robocal.identify.priors`), s0 from the data's residuals; rows a robust method
    rejected carry no information."""
    J = problem.jacobian(out.state, space)
    r = problem.residuals(out.state)
    n_rows = None
    if out.item_weights is not None:
        sw = np.sqrt(np.repeat(out.item_weights, problem.item_rows()))
        J, r, n_rows = J * sw[:, None], r * sw, int(np.count_nonzero(sw))
    return covariance(J, r, n_rows, space.prior_weight)


PARTNER_CORRELATION = 0.9  # |correlation| above which two estimates are reported as confounded
# The calibrated model is called worse than the nominal on validation data when its mean squared
# item error exceeds the nominal's by more than this many standard errors of the paired difference
# (one-sided 1 %): a calibration that changes nothing the data see (a positioner whose errors the
# frames absorb) scatters a few % either way on the same poses, which is no finding
WORSE_VALIDATION_Z = 2.33


def _partners(cov: np.ndarray, names: list[str]) -> dict[str, list[str]]:
    """Per unknown: the (up to 4) others its estimate is most correlated with beyond
    `PARTNER_CORRELATION`."""
    corr = np.abs(correlation(cov))
    np.fill_diagonal(corr, 0.0)
    return {n: [names[j] for j in np.argsort(-corr[i])[:4] if corr[i, j] > PARTNER_CORRELATION]
            for i, n in enumerate(names)}


def _as_sets(data, what: str) -> list:
    """One Measurements or a list of them -> a non-empty list."""
    sets = [] if data is None else list(data) if isinstance(data, list | tuple) else [data]
    if what == "calibration" and not sets:
        raise IdentificationError("a calibration needs at least one measurement set")
    bad = [type(d).__name__ for d in sets if not isinstance(d, Measurements)]
    if bad:
        raise DataError(f"the {what} data must be robocal Measurements (rc.Measurements.load(...)), "
                        f"got {bad}")
    return sets


def _judge(problem: CalibrationProblem, start, states: tuple[State, State], data, force: bool,
           warnings: list[str]) -> Judged:
    """Statistics of ``data`` with the two states' robots, the nuisance (planes) carried over;
    the calibrated model must fit them as a robot can (another robot's data otherwise). Rows that
    repeat calibration poses are then left out (warned; DataError when all do)."""

    def judged(rows) -> Judged:
        vproblem = CalibrationProblem(start, rows)
        carried = tuple(vproblem.carried_state(s.robot, problem.export_nuisance(s)) for s in states)
        return Judged(data=rows, problem=vproblem, states=carried,
                      errors=tuple(vproblem.position_errors(s) for s in carried))

    result = judged(data)
    try:
        check_residual(bulk_rms_mm(result.errors[1]), result.problem.modelled_points(result.states[1]),
                       f"the validation data (the best {BULK_PERCENT} % of its measurements)", force=force,
                       warnings=warnings)
    except PlausibilityError as exc:  # another SMR nest or tool is the calibrated model's finding
        raise refused_validation(exc, result) from None
    what = f"the validation data {data.label or ''}".strip()
    rows, repeated = independent(data, problem.datasets, what)
    if repeated:
        warnings.append(f"{what}: {repeated} of its {len(data)} rows repeat calibration poses (joints within "
                        f"{JOINT_REPEAT_TOL_DEG:g} {tolerance_unit(data)}): the held-out figures are "
                        f"computed on the other {len(rows)} rows only")
        result = replace(judged(rows), repeated=repeated)
    if significantly_worse(*result.errors):
        warnings.append(f"the calibrated model is worse than the nominal on the validation data "
                        f"{data.label} ({result.before['rms']:.4g} -> {result.after['rms']:.4g} mm RMS): the "
                        "calibration does not carry over (too few or clustered poses, or validation data "
                        "from another setup)")
    return result


def significantly_worse(before: np.ndarray, after: np.ndarray) -> bool:
    """Whether item errors ``after (N,)`` are worse than ``before (N,)`` on the same items beyond
    sampling: their mean square larger by more than WORSE_VALIDATION_Z standard errors of the
    paired squared differences (any increase with fewer than 3 items)."""
    d = np.asarray(after, float) ** 2 - np.asarray(before, float) ** 2
    if d.size < 3:
        return bool(d.mean() > 0) if d.size else False
    se = d.std(ddof=1) / np.sqrt(d.size)
    return bool(d.mean() > WORSE_VALIDATION_Z * se)


def _rows(robot=None, data=None, *args, **kwargs) -> int:
    """The measurement rows of a calibration's ``data`` (one set or several; 0 for what is not
    measurements: the calibration itself then refuses it)."""
    try:
        return sum(len(d) for d in data) if isinstance(data, list | tuple) else len(data)
    except TypeError:
        return 0


@memory_guard("the calibration")
@few_threads(_rows)
def calibrate(robot, data, method: str | None = None, params="auto", validation=None, *,
              register_frames: bool = True, rtol: float = DEFAULT_RTOL, seed: int = 0,
              progress=None, nongeometric="default", force: bool = False, sigma: dict | None = None,
              warm_start: CalibrationResult | None = None, hold_out: int | None = None,
              instrument: str | None = None, variance_components: bool | None = None,
              priors: str | dict | PriorSpec | None = None, **options) -> CalibrationResult:
    """Calibrate ``robot`` (nominal model) against ``data``: Measurements, or a list of them of
    any kinds (points, poses, planes, distances) identified together in one problem, each set
    weighted by its noise (its sigma column, else ``sigma`` {kind: m}, else
    `robocal.identify.problem.KIND_SIGMA`).

    The pipeline: register the measurement frame (and SMR offsets) to the nominal model, keep the
    identifiable parameters, solve, then compute the covariance and the before/after statistics.

    Parameters
    ----------
    robot : Robot or Cell
        The nominal model; a work cell (`robocal.kinematics.workcell.Cell`) is calibrated body by
        body in one tracker frame (`robocal.calibration.cell`: returns a ``CellCalibration``).
    data : Measurements or list of Measurements, or CellMeasurements
        The calibration data; several sets (of any kinds) are identified together. Of a cell: its
        rows split per body (`robocal.data.cell_measurements.CellMeasurements`).
    method : str, optional
        ``'lsq'``, ``'robust'`` (outlier rejection), or another registered solver; default
        ``'robust'`` when an instrument with heavy-tailed errors (motion capture, a camera) took
        the data, else ``'lsq'`` (`robocal.data.instruments.default_method`).
    params : 'auto', 'all' or list of str
        The free parameters: ``'auto'`` the default free set with the unidentifiable ones
        dropped, ``'all'``, or names (see ``Robot.parameter_names``).
    validation : Measurements or list of Measurements, optional
        Held-out sets judged with the calibrated model, each in its own unit.
    register_frames : bool, default True
        Fit the measurement frame and SMR offsets to the nominal model first.
    rtol : float
        Relative singular-value threshold below which a parameter is not identifiable.
    seed : int, default 0
        Seed of the stochastic solvers and of the cross-validation folds.
    progress : bool or callable, optional
        True shows a bar on a terminal; a callable is called as ``progress(iteration, rms)``.
    nongeometric : str, list of str or None, default 'default'
        The joint-error terms identified with the geometry by lsq or robust (see
        `robocal.kinematics.joint_errors`): term names and explicit parameter names, e.g.
        ``'compliance,backlash,travel'`` or ``'gear2_c1,cyc4_50_s,cyc4_50_c'``; ``'cyclic'``
        searches the frequencies of cyclic errors in the data first; ``'auto'`` chooses the terms
        by cross-validation on ``data`` (`robocal.calibration.model_selection`; the result's
        ``model_selection`` holds the table); ``'default'`` is ``'auto'`` for lsq and robust on one
        tracker data set (points or poses) of at least `AUTO_DEFAULT_MIN_POSES` poses, else none;
        None or ``'none'``: the geometric model only. The calibrated robot carries the terms and
        its fk applies them.
    force : bool, default False
        Turn the plausibility errors into warnings.
    sigma : dict of str to float, optional
        Noise (1 sigma, metres) per data kind for the sets without a sigma column, e.g.
        ``{"point": 2e-5}``.
    warm_start : CalibrationResult, optional
        A result of the same robot and data whose start model (no new registration) and final
        estimate start this one; the parameter selection is the one without it.
    hold_out : int, optional
        Judge on the last ``hold_out`` poses of the one calibration set (file order) and
        calibrate on the rest (no ``validation`` then); recorded in ``provenance["hold_out"]``.
    instrument : str, optional
        The instrument that took the sets declaring none (``tracker``, ``mocap``, ``camera``;
        `robocal.data.instruments`): its documented noise weighs them, its tails choose the method.
    variance_components : bool, optional
        Estimate the position and rotation noise of 6-D sets from the data (iterated variance
        components, `robocal.identify.variance_components`; ``result.variance_components``);
        default: for camera sets and 6-D sets of a declared instrument other than a tracker.
    priors : str, dict or PriorSpec, optional
        The parameter priors' class and group scales, on top of the model file's ``priors:``
        block: ``'class=service,zeros=3deg,lengths=10mm'``, the same as a mapping, or a
        `robocal.kinematics.prior_spec.PriorSpec` (docs/priors.md). Groups not given start from
        the class default and are widened where the data ask for it (empirical Bayes,
        `robocal.identify.evidence`); ``estimate=no`` keeps them fixed. The result's
        ``prior_scales`` says what was used.
    **options
        Solver options (e.g. ``k0``, ``k1``, ``ridge`` for ``'robust'``; checked against its
        signature).

    Returns
    -------
    CalibrationResult
        The calibrated model (``result.robot``), the statistics before and after (mm), the
        parameters with their uncertainty, identifiability and warnings; ``error_model_choice``
        says why the default error model is the geometric one.

    Raises
    ------
    IdentificationError
        The data cannot support the calibration (too few poses), or an unknown method or
        solver option, or a method that cannot take the requested terms.
    PlausibilityError
        Data and model disagree beyond what real robots do (`robocal.identify.plausibility`;
        ``force=True`` turns those into warnings); the data's own diagnosis first when it names
        the cause (`robocal.trust.diagnosis.diagnosed`).
    DataError
        Invalid data (shapes, joint count, units), or a ``hold_out`` the data cannot give.

    See Also
    --------
    rc.CalibrationResult : What it returns.
    rc.analyze : Which parameters joint values can identify, before measuring.
    rc.evaluate : A model's errors on held-out data.
    rc.plan_poses : Plan the poses to measure.
    rc.compensate : Use the calibrated model on targets.

    Examples
    --------
    >>> import robocal as rc
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> sim = rc.simulate_tracker(nominal, 40, noise_mm=0.01, seed=2)  # 0.5 mm-size errors
    >>> fit, check = sim.data.split_poses(0.75, seed=0)
    >>> result = rc.calibrate(nominal, fit, validation=check, nongeometric=None)
    >>> result.before["rms"] > 0.5, result.after["rms"] < 0.03  # mm, on the calibration poses
    (True, True)
    >>> result.validation["rms"] < 0.03  # mm, on the held-out poses
    True
    >>> "d1" in result.identifiability.dropped  # the base frame absorbs d1
    True
    """
    if isinstance(robot, Cell):  # one calibration per body, in one tracker frame (robocal.calibration.cell)
        return calibrate_cell(robot, data, calibrate, params=params, validation=validation, method=method,
                              rtol=rtol, seed=seed, progress=progress, nongeometric=nongeometric, force=force,
                              sigma=sigma, hold_out=hold_out, instrument=instrument,
                              variance_components=variance_components, priors=priors, **options)
    datasets, validations = (declared(_as_sets(d, role), instrument)
                             for d, role in ((data, "calibration"), (validation, "validation")))
    method = default_method(datasets) if method is None else method
    robot = with_priors(robot, priors)
    if hold_out is not None:
        datasets, validations = split_hold_out(datasets, validations, hold_out)
    try:
        result = _calibrate_sets(robot, datasets, validations, method, params, register_frames, rtol, seed,
                                 progress, nongeometric, force, sigma, warm_start, options,
                                 components=variance_components)
    except HeldOutError:  # the calibrated model's diagnosis of the validation data
        raise
    except PlausibilityError as exc:  # the data's own diagnosis first when it tells more
        raise diagnosed(exc, robot, [*datasets, *validations]) from None
    if hold_out is not None:  # the JSON and the report name the split (docs/result-json.md)
        result.provenance["hold_out"] = hold_out
    if robot.priors is not None:
        result.settings["priors"] = robot.priors.to_dict()
    return result


def with_priors(robot, priors: str | dict | PriorSpec | None):
    """``robot`` with ``priors`` (text, mapping or PriorSpec) on top of its own (the model file's);
    ModelError naming the bad item."""
    if priors is None:
        return robot
    spec = priors if isinstance(priors, PriorSpec) else PriorSpec.from_mapping(priors)
    return robot.with_priors((robot.priors or PriorSpec()).merged(spec))


def split_hold_out(datasets: list, validations: list, n: int) -> tuple[list, list]:
    """([the one calibration set without its last ``n`` poses (file order)], [those poses]): the
    held-out validation of ``calibrate(..., hold_out=n)``.

    Raises
    ------
    DataError
        Several calibration sets, validation sets given as well, or ``n`` not between 1 and the
        number of poses - 1.
    """
    if validations or len(datasets) > 1:
        raise DataError("--hold-out splits one calibration file: give one file and no --validate")
    data = datasets[0]
    if not 0 < n < data.n_poses:
        raise DataError(f"--hold-out must be between 1 and {data.n_poses - 1} (the data have "
                        f"{data.n_poses} poses)")
    calibration = data.first_poses(data.n_poses - n)
    return [calibration], [data.subset(~np.isin(data.pose_id, calibration.pose_id))]


def _calibrate_sets(robot, datasets: list, validations: list, method: str, params, register_frames: bool,
                    rtol: float, seed: int, progress, nongeometric, force: bool, sigma: dict | None,
                    warm_start: CalibrationResult | None, options: dict, components: bool | None = None
                    ) -> CalibrationResult:
    """`calibrate` of the data sets as lists."""
    check_options(method, options)
    spec = resolve_nongeometric(nongeometric, method, datasets)
    rows = sum(len(d) for d in datasets)
    check_memory(calibration_bytes(rows, spec == "auto"), f"calibrating {rows} measurement rows"
                 + (" with the default error-model search" if spec == "auto" else ""))
    if spec and method not in NONGEOMETRIC_METHODS:
        raise IdentificationError(
            f"non-geometric terms are identified by the methods {', '.join(NONGEOMETRIC_METHODS)}; "
            f"{method!r} searches the geometric parameters only (calibrate with lsq first, or "
            "drop --nongeometric)")
    fit = partial(_calibrate, robot, datasets, method, params, register_frames=register_frames,
                  rtol=rtol, seed=seed, progress=progress, force=force, sigma=sigma, options=options,
                  components=components)
    terms = [] if not spec or spec == "auto" else parse_terms(spec)
    if warm_start is not None and (spec == "auto" or "cyclic" in terms):
        raise IdentificationError("a warm start goes with named joint-error terms; nongeometric='auto' "
                                  "and 'cyclic' make their own start")
    if spec == "auto":
        if len(datasets) != 1:
            raise IdentificationError("nongeometric='auto' chooses the error model on one calibration "
                                      "data set: name the terms for several sets")
        # robust's IGG3 weights follow its path: its final fit starts from nominal, like the robust
        # calibration of the chosen model named explicitly (lsq reaches the same minimum either way)
        result = select_error_model(fit, datasets[0], validations, seed=seed, rtol=rtol,
                                    warm_final=method == "lsq")
        result.settings["nongeometric"] = "auto"
    elif "cyclic" in terms:
        result = calibrate_cyclic(fit, [t for t in terms if t != "cyclic"], validations)
    else:
        result = fit(terms, validations, warm_start)
    predicted = prediction(result)
    result.held_out = judge_held_out(result.robot, predicted, result.judged, result.warnings)
    if (worse := worse_than_start(result.validation_before, result.validation)) is not None:
        result.warnings.append(worse)
    if result.held_out is not None:  # the validated figure only as far as the prediction explains it
        predicted = result.held_out.validated(predicted, result.validation["rms"])
    result.predicted_accuracy, more = predict(result.robot, predicted,
                                              np.vstack([d.joints for d in result.problem.datasets]))
    result.warnings += more
    result.error_model_choice = _default_geometric(nongeometric, method, datasets)
    return result


def _default_geometric(spec, method: str, datasets: list) -> str | None:
    """Why the default error model is the geometric one (``'geometric (why)'``), when
    ``spec`` is 'default' and the default does not choose by cross-validation (which prints its
    table): the method, several files, the data's kind or too few poses."""
    if not isinstance(spec, str) or spec.strip().lower() != "default":
        return None
    if method not in NONGEOMETRIC_METHODS:
        why = f"method {method} estimates the geometric parameters only"
    elif len(datasets) != 1:
        why = (f"{len(datasets)} calibration files: the default chooses non-geometric terms on one tracker "
               "data set; name them with --nongeometric to identify them")
    elif (data := datasets[0]).kind not in AUTO_DEFAULT_KINDS:
        why = f"{data.kind} data: the default chooses non-geometric terms on tracker data (points, poses)"
    elif data.n_poses < AUTO_DEFAULT_MIN_POSES:
        why = (f"{data.n_poses} poses: the default chooses non-geometric terms by cross-validation from "
               f"{AUTO_DEFAULT_MIN_POSES} poses on; name them with --nongeometric to identify them anyway")
    else:
        return None
    return f"geometric ({why})"


def resolve_nongeometric(spec, method: str, datasets: list) -> str | list | None:
    """The joint-error terms ``spec`` asks for: 'default' becomes 'auto' for lsq/robust on one
    tracker data set of at least AUTO_DEFAULT_MIN_POSES poses (else None), 'none' becomes None."""
    word = spec.strip().lower() if isinstance(spec, str) else None
    if word in ("none", ""):
        return None
    if word == "default":
        enough = len(datasets) == 1 and datasets[0].kind in AUTO_DEFAULT_KINDS \
            and datasets[0].n_poses >= AUTO_DEFAULT_MIN_POSES
        return "auto" if method in NONGEOMETRIC_METHODS and enough else None
    return word if word == "auto" else spec


def _calibrate(robot, datasets: list, method: str, params, terms: list[str], validations: list,
               warm_start: CalibrationResult | None = None, *, register_frames: bool, rtol: float,
               seed: int, progress, force: bool, sigma: dict | None, options: dict,
               components: bool | None = None) -> CalibrationResult:
    """One calibration with the joint-error terms (and explicit parameter names) ``terms``; the
    arguments of `calibrate` (``components``: its ``variance_components``)."""
    for d in datasets + validations:
        d.check_against(robot)
    n_smr = max(d.n_smr for d in datasets)
    for v in validations:
        if v.n_smr > n_smr:
            raise DataError(f"the validation data use {v.n_smr} SMRs but the calibration data "
                            f"{n_smr}: judge a calibration on data measured with the same SMRs")
    warnings: list[str] = []
    for role, sets in (("calibration", datasets), ("validation", validations)):
        for d in sets:
            check_joint_limits(robot, d, f"the {role} data {d.label or ''}".strip(), force=force,
                               warnings=warnings)
    start = _start_model(robot, datasets, register_frames, force, warnings) if warm_start is None \
        else warm_start.start
    declared = list(dict.fromkeys(start.joint_error_names + candidate_names(start.n_joints, terms)))
    declared_start = start.with_joint_errors(declared).with_reference_temperature(
        thermal_reference([d.temperature for d in datasets])).with_calibrated_conditions(  # T_ref: the mean
        conditions_range([d.conditions for d in datasets]))
    problem = CalibrationProblem(declared_start, datasets, sigma=sigma)
    state0 = problem.start(declared_start)
    if register_frames and warm_start is None:
        state0 = _probe_fitted(problem, state0, seed)
    errors0 = problem.position_errors(state0)
    check_residual(bulk_rms_mm(errors0), problem.modelled_points(state0),
                   f"the calibration data (nominal model, frames fitted; the best {BULK_PERCENT} % of its "
                   "measurements)", force=force, warnings=warnings)
    space, ident, more, prior_robot, scales = _estimated_space(problem, state0, params, rtol, problem.n_poses)
    state0 = State(prior_robot, state0.nuisance)  # carries the group scales used (every later prior)
    warnings += more
    first = state0 if warm_start is None else _warm_state(problem, warm_start, declared_start, space)
    def solve(state: State) -> SolverResult:
        return _run_solver(method, problem, state, space, seed, progress, options)

    out, found = fit_components(solve, problem, first, space, chosen_components(problem, components))
    cov = _covariance(problem, out, space)
    check_corrections(state0.robot, out.state.robot, space.robot,
                      sigma=dict(zip(space.names, np.sqrt(np.maximum(np.diag(cov), 0.0)), strict=True)),
                      confounded={**_partners(cov, space.names), **ident.confounded_with}, force=force,
                      warnings=warnings,
                      prior=dict(zip(space.robot, stated_sigma(state0.robot, space.robot), strict=True)))
    if not out.success:
        warnings.append(out.message)
    if method == "lsq" and out.item_weights is not None:
        warnings.append(_gross_warning(out.item_weights))
    estimated_terms = [n for n in space.robot if block_of(n) == "joint_errors"]
    final_robot = out.state.robot.with_joint_errors(start.joint_error_names + [
        n for n in estimated_terms if n not in start.joint_error_names])
    result = CalibrationResult(
        robot=final_robot, start=start, method=method, identifiability=ident, space=space,
        covariance=cov, solver=out, prior_scales=scales,
        errors=(errors0, problem.position_errors(out.state)), problem=problem, initial=state0,
        warnings=warnings, settings={"params": params if isinstance(params, str) else list(params),
                                     "seed": seed, "rtol": rtol, "nongeometric": ",".join(terms) or "none",
                                     "register_frames": register_frames, "force": force, **_plain(options)},
        provenance={"created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                    "robocal_version": __version__,
                    "robot": {"name": robot.name, "description": robot.description},
                    "data": [d.source for d in datasets], "validation": [v.source for v in validations],
                    "fingerprints": {"data": [fingerprint(d.joints) for d in datasets],
                                     "validation": [fingerprint(v.joints) for v in validations]},
                    "sigma_mm": {k: v * 1e3 for k, v in (sigma or {}).items()},
                    "instruments": [instrument_of(d) or None for d in datasets]})
    result.variance_components = found
    warnings += [c.warning for c in found if c.warning]
    _check_consistency(result, sigma, seed, force)
    states = (state0, State(final_robot, out.state.nuisance))
    result.judged = [_judge(problem, start, states, v, force, warnings) for v in validations]
    if (shifts := result.validation_shifts) is not None and shifts.significant:
        warnings.append(shifts.sentence())
    if terms:
        result.nongeometric = _nongeometric_section(result, terms, estimated_terms)
    return result


def _check_consistency(result: CalibrationResult, sigma: dict | None, seed: int, force: bool) -> None:
    """The residual test of the fit (:mod:`robocal.trust.consistency`) into the result and its
    warnings; PlausibilityError (``force``: a warning) when the fit is worse than nominal;
    IdentificationError when its robust weights rejected every measurement."""
    problem = result.problem
    weights = result.solver.item_weights
    if weights is not None and not np.any(weights):  # nothing left to judge the fit on
        raise IdentificationError(
            "the fit's robust weights rejected every measurement (each beyond its robust sigmas): the "
            "data do not fit the model, or one group of residuals is noise-free (simulated 6-D data "
            "without orientation noise, whose estimated rotation noise goes to 0); check the data, or "
            "use the lsq method without variance components")
    result.consistency = check_fit(result.state.robot, result.start, problem.observations,
                                   problem.item_error_vectors(result.state),
                                   result.space.size, sigma=sigma, seed=seed, priors=result.prior_scales)
    kept = slice(None) if weights is None else weights != 0
    before, after_rms = (position_stats(e[kept])["rms"] for e in result.errors)
    # a solve stopped by a limit or the user's threshold may end anywhere: that is said elsewhere;
    # a converged fit worse than nominal absorbed a mistake in the data
    check_not_worse(before, after_rms, "the calibration data", result.consistency.diagnosis, force=force,
                    warnings=result.warnings, refuse=result.solver.status == Status.CONVERGED)
    result.warnings += result.consistency.warnings("the calibration")


def _warm_state(problem: CalibrationProblem, warm: CalibrationResult, start, space: ParameterSpace) -> State:
    """The start of a warm-started solve: ``warm``'s final geometry and nuisance, its joint-error
    values for the parameters ``space`` estimates (0 for the others: the delivered model keeps only
    the estimated joint errors, so one held at ``warm``'s value would be fitted with and then lost)."""
    if warm.robot.n_joints != start.n_joints or warm.problem.kind != problem.kind \
            or warm.problem.nuisance_names != problem.nuisance_names:
        raise IdentificationError("warm_start must be a calibration of the same robot with the same "
                                  "kind of data (and the same planes or SMRs)")
    robot = warm.state.robot.with_joint_errors(start.joint_error_names)
    kept = set(space.robot) | set(warm.start.joint_error_names)  # the start model's own stay
    held = {nm: 0.0 for nm in start.joint_error_names if nm not in kept}
    return State(robot.with_values(held) if held else robot, warm.state.nuisance)


def _nongeometric_section(result: CalibrationResult, terms: list[str], estimated: list[str]) -> dict:
    """The result's joint-error summary: the terms asked for, the parameters estimated (with
    their 1-sigma, SI) and those left out."""
    sigma = dict(zip(result.unknowns, result.sigma, strict=True))
    values = dict(zip(result.robot.parameter_names, result.robot.values, strict=True))
    asked = {t if t in TERMS else term_of(t) for t in terms}
    return {"terms": [t for t in TERMS if t in asked], "kept": estimated,
            "dropped": [n for n in result.identifiability.names
                        if block_of(n) == "joint_errors" and n not in estimated],
            "parameters": [{"name": n, "estimate": float(values[n]), "sigma": float(sigma[n])}
                           for n in estimated]}


def analyze(robot, joints_or_data, kind: str = "point", params="auto",
            rtol: float = DEFAULT_RTOL, noise_mm: float = 0.02) -> Identifiability:
    """Identifiability of a pose set before measuring: only the joints matter.

    ``joints_or_data`` is a ``(N, n)`` array (rad) or Measurements; the observations are taken
    as the model's own predictions, so no measurement is needed. With the priors every fit
    carries (`robocal.identify.priors`) and the measurement noise ``noise_mm``, the parameters
    are judged as the calibration will judge them, in the words of `robocal.identify.vocabulary`
    (`robocal.trust.posterior.judge`): ``kept`` the data determine (estimated),
    ``undetermined`` only their priors do (not determined by these data: held near nominal by
    their prior), ``dropped`` no poses can (not identifiable: exactly confounded with other
    parameters or a frame, or without effect). Of Measurements, each row keeps its SMR.

    Parameters
    ----------
    robot : Robot
        The nominal model.
    joints_or_data : array_like, shape (N, n), or Measurements
        The pose set, radians (of Measurements: its joints and SMR indices).
    kind : {'point', 'pose'}
        What will be measured at each pose.
    params : 'auto', 'all' or list of str
        The candidate free parameters, as in `calibrate`.
    rtol : float
        Relative singular-value threshold below which a parameter is not identifiable.
    noise_mm : float, default 0.02
        The measurement noise (1 sigma per coordinate), millimetres: how much the data weigh
        against the priors.

    Returns
    -------
    Identifiability
        ``kept``, ``undetermined`` (with ``prior_ratio``) and ``dropped`` parameters (with
        ``confounded_with``), ``rank``, ``condition_number``, ``singular_values`` and
        ``observability``.

    Raises
    ------
    DataError
        Joints of the wrong shape or with NaN.

    See Also
    --------
    rc.calibrate : The calibration itself.
    rc.plan_poses : Poses chosen to identify the parameters well.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> q = np.random.default_rng(0).uniform(robot.limits[:, 0], robot.limits[:, 1], (40, 6))
    >>> ident = rc.analyze(robot, q)
    >>> ident.rank == len(ident.kept)
    True
    >>> "d1" in ident.dropped, ident.confounded_with["d1"]  # not identifiable: base.z absorbs it
    (True, ['base.z'])
    """
    q = robot.check_joints(getattr(joints_or_data, "joints", joints_or_data))
    smr = getattr(joints_or_data, "smr", None)
    smr = None if smr is None or smr.max(initial=0) > len(robot.smr) else smr
    T = robot.fk(q, smr=smr)
    readings = kind_spec(kind).readings(T)
    data = Measurements.from_arrays(kind, q, smr=smr,  # every SMR's rows, as measured
                                    pose_id=getattr(joints_or_data, "pose_id", None), **readings)
    if not (np.isfinite(noise_mm) and noise_mm > 0):
        raise DataError(f"the measurement noise must be > 0 mm, got {noise_mm}")
    ident = posterior_analysis(robot, data, Noise(sigma_m=float(noise_mm) * 1e-3), params, rtol)
    n_smr = 1 if smr is None else int(smr.max(initial=0)) + 1
    return separate(ident, unidentifiable(robot, kind, ident.names, n_smr, rtol), robot)


def _plain(options: dict) -> dict:
    return {k: v for k, v in options.items() if isinstance(v, str | int | float | bool)}
