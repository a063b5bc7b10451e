"""``rc.calibrate``: registration, identifiability, a solver, uncertainty and statistics.

The pipeline: fit the tracker frame and SMR offsets to the nominal model (registration), pick
the identifiable parameters (QR with pivoting), run the chosen method, then compute the
covariance of the estimate and the before/after position statistics.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.errors import IdentificationError
from robocal.identify.identifiability import DEFAULT_RTOL, Identifiability
from robocal.identify.identifiability import analyze as analyze_jacobian
from robocal.identify.nongeometric import parse_terms
from robocal.identify.problem import CalibrationProblem, State, candidate_parameters
from robocal.identify.solvers import SolverOutput, check_options, get_solver
from robocal.identify.uncertainty import correlation, covariance, tcp_position_covariance
from robocal.kinematics.yaml_io import write_atomic
from robocal.progress import Progress
from robocal.report.metrics import position_stats

RESULT_FORMAT = "robocal-result/1"
NONGEOMETRIC_METHODS = ("lsq", "robust")  # the methods that estimate the joint-error terms
AUTO_DEFAULT_KINDS = ("point", "pose")  # tracker data: where nongeometric="auto" is the default ...
AUTO_DEFAULT_MIN_POSES = 100  # ... from this many poses on (20 held out per cross-validation fold)


def _display(unit: str) -> tuple[str, float]:
    return ("mm", 1e3) if unit == "m" else ("deg", 180.0 / np.pi)


@dataclass
class CalibrationResult:
    """Everything a calibration found; ``to_dict()`` is the JSON of docs/result-json.md."""

    robot: object
    start: object
    method: str
    identifiability: Identifiability
    names: list[str]
    unknowns: list[str]
    covariance: np.ndarray
    solver: SolverOutput
    before: dict
    after: dict
    problem: CalibrationProblem = field(repr=False)
    validation_before: dict | None = None
    validation: dict | None = None
    validation_data: object = field(default=None, repr=False)
    warnings: list[str] = field(default_factory=list)
    settings: dict = field(default_factory=dict)
    nongeometric: dict | None = None
    model_selection: dict | None = None

    @property
    def state(self) -> State:
        return self.solver.state

    @property
    def sigma(self) -> np.ndarray:
        """1-sigma of every unknown (robot parameters then nuisance), SI units."""
        return np.sqrt(np.maximum(np.diag(self.covariance), 0.0))

    @property
    def after_inliers(self) -> dict | None:
        """Statistics after calibration without the rejected observations (robust), else None."""
        rejected = self.rejected
        if not len(rejected):
            return None
        keep = np.setdiff1d(np.arange(self.problem.observation.n_items), rejected)
        return position_stats(self.problem.position_errors(self.state)[keep])

    @property
    def correlation(self) -> np.ndarray:
        return correlation(self.covariance)

    @property
    def rejected(self) -> np.ndarray:
        """Indices of the measurement items a robust method rejected (weight 0)."""
        w = self.solver.item_weights
        return np.zeros(0, int) if w is None else np.flatnonzero(w == 0)

    def predict_position_sigma(self, q) -> np.ndarray:
        """1-sigma ``(N, 3)`` (m) of the calibrated model's TCP position at joints ``q``."""
        k = len(self.names)
        cov = tcp_position_covariance(self.robot, self.robot.check_joints(q), self.names,
                                      self.covariance[:k, :k])
        return np.sqrt(np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0))

    def parameter_table(self) -> list[dict]:
        """Every candidate parameter (and nuisance) with nominal, estimate, correction, sigma."""
        robot, start = self.robot, self.start
        sigma = dict(zip(self.unknowns, self.sigma, strict=True))
        units = dict(zip(robot.parameter_names, robot.parameter_units(), strict=True))
        values, nominal = robot.values, start.nominal
        rows = []
        dropped = set(self.identifiability.dropped)
        for name in self.identifiability.names:
            if name in units:
                i = robot.indices([name])[0]
                unit, f = _display(units[name])
                nom, est = nominal[i] * f, values[i] * f
            else:  # nuisance (e.g. plane coefficients): reported in its own unit
                j = self.problem.nuisance_names.index(name)
                unit, f = "", 1.0
                nom, est = float(self.problem.observation.nuisance_start(start)[j]), \
                    float(self.state.nuisance[j])
            status = "dropped" if name in dropped else "estimated"
            s = sigma.get(name)
            rows.append({"name": name, "unit": unit, "nominal": float(nom), "estimate": float(est),
                         "correction": float(est - nom),
                         "sigma": None if s is None else float(s * f), "status": status})
        return rows

    def _observations(self, data, problem, start_state, final_state) -> dict:
        obs = problem.observation
        measured = getattr(obs, "measured", None)
        measured = None if measured is None or measured.ndim != 2 else measured * 1e3
        weights = self.solver.item_weights if data is self.problem.data else None
        if weights is not None:
            weights = weights[obs.item_of_rows()]  # one per data row
        return {
            "pose_id": data.pose_id.tolist(), "source_row": data.source_row.tolist(),
            "smr": data.smr.tolist(), "joints_deg": np.rad2deg(data.joints).tolist(),
            "measured": None if measured is None else measured.tolist(),
            "model_before": (obs.modelled_points(start_state.robot, start_state.nuisance) * 1e3).tolist(),
            "model_after": (obs.modelled_points(final_state.robot, final_state.nuisance) * 1e3).tolist(),
            "weight": None if weights is None else weights.tolist(),
            "plane": None if data.plane is None else data.plane.tolist(),
        }

    def to_dict(self) -> dict:
        """The result as plain data (mm, deg), per docs/result-json.md."""
        from robocal import __version__

        ident = self.identifiability
        k = len(self.unknowns)
        errors = self.problem.position_errors(self.state)
        out = {
            "format": RESULT_FORMAT,
            "robocal_version": __version__,
            "robot": {"name": self.robot.name, "description": self.robot.description,
                      "n_joints": self.robot.n_joints},
            "data": {"file": self.problem.data.source, "kind": self.problem.kind,
                     "n_poses": int(self.problem.data.n_poses),
                     "n_observations": int(len(self.problem.data))},
            "method": self.method,
            "settings": self.settings,
            "converged": self.solver.converged,
            "message": self.solver.message,
            "before": self.before,
            "after": self.after,
            **({"after_inliers": self.after_inliers} if self.after_inliers else {}),
            "parameters": self.parameter_table(),
            "dropped": [{"name": n, "reason": "not identifiable from these data",
                         "confounded_with": ident.confounded_with[n]} for n in ident.dropped],
            "identifiability": {key: v for key, v in ident.to_dict().items()
                                if key not in ("kept", "dropped", "confounded_with")},
            "correlation": {"names": self.unknowns,
                            "matrix": np.round(self.correlation, 6).reshape(k, k).tolist()},
            "rejected": [{"source_row": int(self.problem.data.source_row[row]),
                          "pose_id": int(self.problem.data.pose_id[row]),
                          "residual": float(errors[item] * 1e3), "weight": 0.0}
                         for item in self.rejected
                         for row in np.flatnonzero(self.problem.observation.item_of_rows() == item)],
            "observations": self._observations(self.problem.data, self.problem,
                                               self.problem.start(self.start), self.state),
            "history": [{key: float(v) if isinstance(v, float | np.floating) else v
                         for key, v in h.items()} for h in self.solver.history],
            "warnings": self.warnings,
        }
        if self.nongeometric is not None:
            out["nongeometric"] = self.nongeometric
        if self.model_selection is not None:
            out["model_selection"] = self.model_selection
        if self.validation is not None:
            out["data"]["validation_file"] = self.validation_data.source
            out["validation_before"] = self.validation_before
            out["validation"] = self.validation
            vproblem = CalibrationProblem(self.robot, self.validation_data)
            before = carry_over(vproblem, self.problem, self.problem.start(self.start))
            after = carry_over(vproblem, self.problem, State(self.robot, self.state.nuisance))
            out["validation_observations"] = self._observations(self.validation_data, vproblem, before, after)
        return out

    def save_json(self, path) -> None:
        write_atomic(path, json.dumps(self.to_dict(), indent=1, allow_nan=False))

    def summary(self) -> str:
        """A short human summary: before -> after, largest corrections, dropped parameters."""
        b, a = self.before, self.after
        lines = [f"{self.method}: {self.solver.message}",
                 f"calibration set ({b['n']} obs): RMS {b['rms']:.4f} -> {a['rms']:.4f} mm, "
                 f"max {b['max']:.4f} -> {a['max']:.4f} mm"]
        if self.validation is not None:
            vb, va = self.validation_before, self.validation
            lines.append(f"validation set  ({va['n']} obs): RMS {vb['rms']:.4f} -> {va['rms']:.4f} mm, "
                         f"max {vb['max']:.4f} -> {va['max']:.4f} mm")
        links = [r for r in self.parameter_table()
                 if r["status"] == "estimated" and "." not in r["name"]]
        for unit in ("mm", "deg"):
            top = sorted((r for r in links if r["unit"] == unit), key=lambda r: -abs(r["correction"]))[:3]
            if top:
                lines.append(f"largest corrections ({unit}): " + ", ".join(
                    f"{r['name']} {r['correction']:+.4f} ± {r['sigma']:.4f}" for r in top))
        if self.identifiability.dropped:
            lines.append("not identifiable (fixed): " + ", ".join(
                f"{n} (~{'/'.join(self.identifiability.confounded_with[n]) or 'no effect'})"
                for n in self.identifiability.dropped))
        if self.model_selection is not None:
            from robocal.model_selection import selection_table

            lines.append(selection_table(self.model_selection))
        if len(self.rejected):
            lines.append(f"rejected observations: {len(self.rejected)}; without them the calibration "
                         f"set's RMS is {self.after_inliers['rms']:.4f} mm")
        lines += [f"WARNING: {w}" for w in self.warnings]
        return "\n".join(lines)


def _start_model(robot, data, register_frames: bool):
    if data.kind not in ("point", "pose") or not register_frames:
        return robot
    from robocal.data.registration import register

    return register(robot, data)


def calibrate(robot, data, method: str = "lsq", params="auto", validation=None, *,
              register_frames: bool = True, rtol: float = DEFAULT_RTOL, seed: int = 0,
              progress=None, nongeometric="default", warm_start=None, **options) -> CalibrationResult:
    """Calibrate ``robot`` (nominal model) against ``data`` (Measurements).

    method: 'lsq' (default), 'robust', or another registered solver; params: 'auto' (the
    default free set, unidentifiable ones dropped), 'all', or a list of names. ``validation``
    (Measurements) is judged with the calibrated model. ``progress``: True shows a bar on a
    terminal, or a callable ``progress(iteration, rms)``. ``options`` go to the solver (e.g.
    k0, k1, ridge for 'robust'; checked against its signature). ``nongeometric``: terms
    identified with the geometry by lsq or robust, e.g. 'compliance,gear,backlash,travel' or
    explicit parameter names (see robocal.identify.nongeometric); 'cyclic' searches the
    frequencies of cyclic errors in the data first (robocal.identify.frequency_search); 'auto'
    chooses the terms by cross-validation on ``data`` (robocal.model_selection; the result's
    ``model_selection`` holds the table); 'default' is 'auto' for lsq and robust on tracker data
    (points or poses) with at least AUTO_DEFAULT_MIN_POSES poses, else none; None or 'none': the
    geometric model only. The calibrated robot carries the terms and its fk applies them.
    ``warm_start``: a CalibrationResult of the same robot and kind of data whose start model (no
    new registration) and final estimate start this one (the parameter selection is the same as
    without it). Raises IdentificationError when the data cannot support the
    calibration.
    """
    solve = get_solver(method)
    check_options(method, solve, options)
    nongeometric = resolve_nongeometric(nongeometric, method, data)
    if nongeometric and method not in NONGEOMETRIC_METHODS:
        raise IdentificationError(
            f"non-geometric terms are identified by the methods {', '.join(NONGEOMETRIC_METHODS)}; "
            f"{method!r} searches the geometric parameters only (calibrate with lsq first, or "
            "drop --nongeometric)")
    if nongeometric:
        from robocal.model_selection import calibrate_auto, calibrate_cyclic, needs_selection

        mode = needs_selection(nongeometric)
        common = dict(register_frames=register_frames, rtol=rtol, seed=seed, progress=progress, **options)
        if mode == "auto":
            return calibrate_auto(robot, data, method, params, validation, **common)
        if mode == "cyclic":
            return calibrate_cyclic(robot, data, method, params, validation, nongeometric=nongeometric,
                                    **common)
    data.check_against(robot)
    if validation is not None:
        validation.check_against(robot)
    start = _start_model(robot, data, register_frames) if warm_start is None else warm_start.start
    problem = CalibrationProblem(start, data)
    candidates = candidate_parameters(start, problem.observation, params)
    state0 = problem.start(start)
    unknown_candidates = candidates + problem.nuisance_names
    J0 = problem.jacobian(state0, candidates)
    ident = analyze_jacobian(J0, unknown_candidates, data.n_poses, rtol)
    warnings = []
    problem.observation.check_enough(len(unknown_candidates))
    blind = problem.observation.not_observable(start)
    if blind and isinstance(params, str):
        warnings.append(f"{problem.observation.blind_spot}: {', '.join(blind)} are held at their "
                        "nominal values")
    if ident.rank < max(1, len(unknown_candidates) // 2):
        raise IdentificationError(
            f"the pose set is degenerate: only {ident.rank} of {len(unknown_candidates)} parameters "
            f"are identifiable from {data.n_poses} poses; measure poses spread over the workspace")
    if J0.shape[0] <= ident.rank:
        raise IdentificationError(
            f"{J0.shape[0]} residuals cannot determine {ident.rank} identifiable parameters: "
            "measure more poses")
    names = [n for n in ident.kept if n in candidates]
    if len(names) + len(problem.nuisance_names) != ident.rank:
        lost = sorted(set(problem.nuisance_names) - set(ident.kept))
        raise IdentificationError(f"the nuisance parameters {lost} are not identifiable: "
                                  "each plane needs contacts spread over its surface")
    ng_info = None
    if nongeometric:
        from robocal.identify.nongeometric import attach

        state0, ng_info = attach(problem, state0, names, parse_terms(nongeometric), rtol)
    total = options.get("generations") or options.get("iterations") or options.get("epochs")
    with Progress(total, f"calibrate ({method})", quiet=progress is not True) as bar:
        if progress is True:
            def progress(iteration, rms):  # noqa: E306 - the bar's callback
                bar.update(info=f"rms {rms * 1e3:.4f} mm")
        first = state0 if warm_start is None else _warm_state(problem, warm_start, ng_info)
        out = solve(problem, first, names, seed=seed, progress=progress or None, **options)
    if not out.converged:
        warnings.append(out.message)
    if ident.condition_class == "strong":
        warnings.append(f"the normal matrix is strongly ill-conditioned (condition number "
                        f"{ident.condition_number:.3g}): some parameters are poorly determined; "
                        "see the correlation matrix")
    final = out.state
    final_robot = final.robot if ng_info is None else problem.observation.calibrated_robot(final)
    row_w = None if out.item_weights is None else np.repeat(out.item_weights, problem.rows_per_item)
    J = problem.jacobian(final, names)
    r = problem.residuals(final)
    dof_rows = None
    if row_w is not None:
        J, r = J * np.sqrt(row_w)[:, None], r * np.sqrt(row_w)
        dof_rows = int(np.count_nonzero(row_w))  # rejected rows carry no information
    cov = covariance(J, r, dof_rows)
    result = CalibrationResult(
        robot=final_robot, start=start, method=method, identifiability=ident, names=names,
        unknowns=names + problem.nuisance_names, covariance=cov, solver=out,
        before=position_stats(problem.position_errors(state0)),
        after=position_stats(problem.position_errors(final)), problem=problem,
        warnings=warnings, settings={"params": params if isinstance(params, str) else list(params),
                                     "seed": seed, "rtol": rtol, **_plain(options),
                                     "nongeometric": ",".join(parse_terms(nongeometric)) or "none"})
    if validation is not None:
        vproblem = CalibrationProblem(start, validation)
        result.validation_data = validation
        for key, state in (("validation_before", state0), ("validation", State(final_robot, final.nuisance))):
            errors = vproblem.position_errors(carry_over(vproblem, problem, state))
            setattr(result, key, position_stats(errors))
    if ng_info is not None:
        sig = dict(zip(result.unknowns, result.sigma, strict=True))
        ng_info["parameters"] = [{"name": nm, "estimate": float(v), "sigma": float(sig[nm])}
                                 for nm, v in zip(ng_info["kept"], final_robot.joint_errors.values,
                                                  strict=True)]
        result.nongeometric = ng_info
    return result


def resolve_nongeometric(spec, method: str, data):
    """The terms ``spec`` asks for: 'default' becomes 'auto' for lsq/robust on tracker data with
    at least AUTO_DEFAULT_MIN_POSES poses (else None), 'none' becomes None."""
    if isinstance(spec, str) and spec.strip().lower() == "none":
        return None
    if isinstance(spec, str) and spec.strip().lower() == "default":
        enough = data.kind in AUTO_DEFAULT_KINDS and data.n_poses >= AUTO_DEFAULT_MIN_POSES
        return "auto" if method in NONGEOMETRIC_METHODS and enough else None
    return spec


def _warm_state(problem: CalibrationProblem, warm, ng_info: dict | None) -> State:
    """The start of a warm-started solve: ``warm``'s final geometry and nuisance, its joint-error
    values for the names this problem identifies too (0 for the others)."""
    obs = problem.observation
    inner = len(obs.nuisance_names) - (0 if ng_info is None else len(ng_info["kept"]))
    warm_obs = warm.problem.observation
    warm_inner = len(warm_obs.nuisance_names) - len(getattr(warm_obs, "names", []))
    if warm.robot.n_joints != problem.observation.q.shape[1] or warm.problem.kind != problem.kind \
            or warm_inner != inner:
        raise IdentificationError("warm_start must be a calibration of the same robot with the same "
                                  "kind of data (and the same planes or SMRs)")
    nuisance = np.array(warm.state.nuisance[:inner], dtype=float)
    if ng_info is not None:
        previous = {} if warm.robot.joint_errors is None else dict(
            zip(warm.robot.joint_errors.names, warm.robot.joint_errors.values, strict=True))
        nuisance = np.concatenate([nuisance, [previous.get(nm, 0.0) for nm in ng_info["kept"]]])
    return State(warm.state.robot, nuisance)


def analyze(robot, joints_or_data, kind: str = "point", params="auto",
            rtol: float = DEFAULT_RTOL) -> Identifiability:
    """Identifiability of a pose set before measuring: only the joints matter.

    ``joints_or_data`` is a ``(N, n)`` array (rad) or Measurements; the observations are taken
    as the model's own predictions, so no measurement is needed.
    """
    from robocal.data.measurements import Measurements

    q = robot.check_joints(getattr(joints_or_data, "joints", joints_or_data))
    smr = getattr(joints_or_data, "smr", None)
    T = robot.fk(q, smr=None if smr is None or smr.max(initial=0) > len(robot.smr) else smr)
    extra = {"rotations": T[:, :3, :3]} if kind == "pose" else {}
    data = Measurements.from_arrays(kind, q, points=T[:, :3, 3], **extra)
    problem = CalibrationProblem(robot, data)
    names = candidate_parameters(robot, problem.observation, params)
    J = problem.jacobian(problem.start(robot), names)
    return analyze_jacobian(J, names + problem.nuisance_names, data.n_poses, rtol)


def carry_over(vproblem: CalibrationProblem, problem: CalibrationProblem, state: State) -> State:
    """``state`` for judging other data: with the identified nuisance parameters (e.g. the planes
    found on the calibration contacts) when both data sets have the same ones, else re-fitted."""
    if vproblem.nuisance_names == problem.nuisance_names:
        return State(state.robot, state.nuisance)
    return vproblem.start(state.robot)


def _plain(options: dict) -> dict:
    return {k: v for k, v in options.items() if isinstance(v, str | int | float | bool)}


def load_result(path) -> dict:
    """Read a result JSON written by :meth:`CalibrationResult.save_json`."""
    from robocal.errors import DataError

    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise DataError(f"cannot read result file {path}: {exc}") from None
    if not isinstance(data, dict) or data.get("format") != RESULT_FORMAT:
        raise DataError(f"{path} is not a robocal result JSON (format {RESULT_FORMAT})")
    return data
