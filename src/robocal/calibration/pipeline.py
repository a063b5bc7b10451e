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
import json
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from robocal.calibration import conditions
from robocal.calibration.model_selection import calibrate_cyclic, select_error_model, selection_table
from robocal.core.damped_least_squares import Status
from robocal.core.errors import DataError, IdentificationError
from robocal.core.io import load_json, read_text, write_atomic
from robocal.core.progress import Progress
from robocal.core.resources import calibration_bytes, check_memory, few_threads, memory_guard
from robocal.core.schema import RESULT_SCHEMA, validate
from robocal.core.version import __version__
from robocal.data.kinds import kind_spec
from robocal.data.measurements import Measurements
from robocal.data.registration import register
from robocal.identify import vocabulary
from robocal.identify.identifiability import DEFAULT_RTOL, Identifiability, hold
from robocal.identify.identifiability import analyze as analyze_jacobian
from robocal.identify.plausibility import (
    check_corrections,
    check_joint_limits,
    check_residual,
    check_spread,
)
from robocal.identify.priors import linear_analysis, prior_sigma, undetermined
from robocal.identify.problem import CalibrationProblem
from robocal.identify.solvers import SolverResult, check_options, get_solver, iteration_limit
from robocal.identify.space import ParameterSpace, State, block_of
from robocal.identify.structural import separate, unidentifiable
from robocal.identify.uncertainty import correlation, covariance, tcp_position_covariance
from robocal.kinematics.cell import TRACK_IDENTIFIABILITY, is_track_cell
from robocal.kinematics.conditions import range_of as conditions_range
from robocal.kinematics.joint_errors import TERMS, candidate_names, parse_terms, term_of
from robocal.kinematics.thermal import groups_of as thermal_groups_of
from robocal.kinematics.thermal import reference_of as thermal_reference
from robocal.report.metrics import position_stats
from robocal.trust.consistency import Consistency, check_fit, check_not_worse
from robocal.trust.coverage import accuracy_line, predict, prediction
from robocal.trust.file_shifts import FileShifts, file_shifts, pose_means
from robocal.trust.posterior import Noise, posterior_analysis
from robocal.trust.provenance import JOINT_REPEAT_TOL_DEG, fingerprint, independent, tolerance_unit

RESULT_FORMAT = "robocal-result/1"
NONGEOMETRIC_METHODS = ("lsq", "robust")  # the methods that estimate the joint-error terms
AUTO_DEFAULT_KINDS = ("point", "pose")  # tracker data: where nongeometric="auto" is the default ...
AUTO_DEFAULT_MIN_POSES = 100  # ... from this many poses on (20 held out per cross-validation fold)
_DISPLAY = {"m": ("mm", 1e3), "rad": ("deg", 180.0 / np.pi), "rad/m": ("deg/m", 180.0 / np.pi),
            "rad/rad": ("mdeg/deg", 1e3), "1": ("ppm", 1e6),  # "1": a scale (dimensionless)
            "rad/(kg m)": ("deg/(kg m)", 180.0 / np.pi), "1/K": ("1e-6/K", 1e6)}


class _BeforeAfter:
    """Statistics (mm) of ``errors`` (each item's error with the start and the calibrated model, m)."""

    errors: tuple[np.ndarray, np.ndarray]

    @property
    def before(self) -> dict:
        """Statistics (mm) with the start model."""
        return position_stats(self.errors[0])

    @property
    def after(self) -> dict:
        """Statistics (mm) with the calibrated model."""
        return position_stats(self.errors[1])


@dataclass
class Judged(_BeforeAfter):
    """A measurement set judged with the start and the calibrated model: its problem, the two
    states (nuisance carried over from the calibration) and each item's error with them (m)."""

    data: Measurements
    problem: CalibrationProblem
    states: tuple[State, State]
    errors: tuple[np.ndarray, np.ndarray]
    repeated: int = 0  # rows left out: they repeat calibration poses (robocal.trust.provenance)


@dataclass
class CalibrationResult(_BeforeAfter):
    """Everything a calibration found; ``to_dict()`` is the JSON of docs/result-json.md.

    Returned by `robocal.calibrate`; `summary` prints it, `save_json` writes it,
    ``result.robot.save(path)`` writes the calibrated model.

    Attributes
    ----------
    robot : Robot
        The calibrated model (with the declared joint-error terms, which its ``fk`` applies).
    start : Robot
        The registered start model (nominal geometry in the measurement's frame).
    method : str
        The solver used (``'lsq'``, ``'robust'``...).
    identifiability : Identifiability
        Which parameters the data determine: kept, dropped (not identifiable, with what they are
        confounded with) and undetermined (held at nominal), the condition number.
    space : ParameterSpace
        What was estimated: robot parameters, then nuisance (tracker frame, SMRs, planes...).
    covariance : numpy.ndarray, shape (k, k)
        Covariance of the estimated unknowns, SI units (m, rad).
    solver : SolverResult
        The solver's outcome: final state, convergence, iteration history, robust weights.
    errors : tuple of numpy.ndarray, shape (M,) each
        Each calibration item's error in the start and in the final state, metres.
    problem : CalibrationProblem
        The measurement model of the calibration data.
    initial : State
        The start state (registered model, nuisance fitted to it).
    judged : list of Judged
        Each validation set judged with the start and the calibrated model.
    warnings : list of str
        What the user should know (held parameters, implausible corrections with ``force``...).
    settings : dict
        The settings of the run (method, params, rtol, seed, solver options).
    nongeometric : dict or None
        The joint-error terms identified, when any.
    model_selection : dict or None
        The cross-validation table when the terms were chosen automatically.
    provenance : dict
        Versions, date and input files.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> sim = rc.simulate_tracker(nominal, 40, noise_mm=0.01, seed=2)
    >>> result = rc.calibrate(nominal, sim.data, nongeometric=None)
    >>> result.after["rms"] < 0.05 < 0.5 < result.before["rms"]  # mm: from the errors to the noise
    True
    >>> q = sim.data.joints
    >>> error = result.robot.fk(q)[:, :3, 3] - sim.truth.fk(q)[:, :3, 3]  # against the truth, m
    >>> bool(np.abs(error).max() < 5e-5)
    True
    >>> result.predict_position_sigma(q[:2]).shape  # 1-sigma of the predicted TCP, m
    (2, 3)
    """

    robot: object
    start: object
    method: str
    identifiability: Identifiability
    space: ParameterSpace
    covariance: np.ndarray
    solver: SolverResult
    errors: tuple[np.ndarray, np.ndarray] = field(repr=False)
    problem: CalibrationProblem = field(repr=False)
    initial: State = field(repr=False)
    judged: list[Judged] = field(default_factory=list, repr=False)
    warnings: list[str] = field(default_factory=list)
    settings: dict = field(default_factory=dict)
    nongeometric: dict | None = None
    model_selection: dict | None = None
    provenance: dict = field(default_factory=dict)
    consistency: Consistency | None = None
    predicted_accuracy: dict | None = None

    @property
    def state(self) -> State:
        """The final state of the solver (calibrated model and nuisance)."""
        return self.solver.state

    @property
    def names(self) -> list[str]:
        """The estimated robot parameters."""
        return list(self.space.robot)

    @property
    def unknowns(self) -> list[str]:
        """Every estimated unknown (robot parameters, then nuisance)."""
        return self.space.names

    @property
    def validation_before(self) -> dict | None:
        """Statistics (mm) of every validation item with the start model (all files together)."""
        return _combined([j.errors[0] for j in self.judged])

    @property
    def validation(self) -> dict | None:
        """Statistics (mm) of every validation item with the calibrated model (all files)."""
        return _combined([j.errors[1] for j in self.judged])

    @property
    def validation_shifts(self) -> FileShifts | None:
        """The held-out error split into a shift per validation file and the error within the files
        (`robocal.trust.file_shifts`; point and pose files), with two validation files or more."""
        files = [j for j in self.judged if j.data.spec.sees_position]
        errors = [pose_means(j.problem.item_error_vectors(j.states[1])[0], j.data.pose_id) for j in files]
        return file_shifts([j.data.label for j in files], errors)

    def _files(self) -> list[tuple[str, Measurements, np.ndarray, np.ndarray]]:
        """(role, data, errors before, errors after) of every file, calibration then validation."""
        before, after = self.errors
        return [("calibration", data, before[items], after[items])
                for data, items in zip(self.problem.datasets, self.problem.item_blocks(), strict=True)] + \
            [("validation", j.data, *j.errors) for j in self.judged]

    def per_file(self) -> list[dict]:
        """Per measurement file (calibration, then validation): its kind and its statistics (mm)
        before and after; the errors of each kind are in mm (position, plane deviation, distance)."""
        return [{"role": role, "file": data.label, "kind": data.kind, "before": position_stats(before),
                 "after": position_stats(after)} for role, data, before, after in self._files()]

    def per_kind(self) -> dict[str, dict]:
        """Per role and kind (e.g. ``calibration plane``): statistics (mm) after calibration."""
        out: dict[str, list] = {}
        for role, data, _, after in self._files():
            out.setdefault(f"{role} {data.kind}", []).append(after)
        return {key: _combined(parts) for key, parts in out.items()}

    @property
    def sigma(self) -> np.ndarray:
        """1-sigma of every unknown (robot parameters then nuisance), SI units."""
        return np.sqrt(np.maximum(np.diag(self.covariance), 0.0))

    @property
    def after_inliers(self) -> dict | None:
        """Statistics after calibration without the rejected observations (robust), else None."""
        w = self.solver.item_weights
        if w is None or not (w == 0).any():
            return None
        return position_stats(self.errors[1][w != 0])

    @property
    def correlation(self) -> np.ndarray:
        """Correlation matrix ``(k, k)`` of the estimated unknowns (order of `unknowns`)."""
        return correlation(self.covariance)

    @property
    def rejected(self) -> np.ndarray:
        """Indices of the measurement items a robust method rejected (weight 0)."""
        w = self.solver.item_weights
        return np.zeros(0, int) if w is None else np.flatnonzero(w == 0)

    def predict_position_sigma(self, q) -> np.ndarray:
        """1-sigma ``(N, 3)`` (m) of the calibrated model's TCP position at joints ``q``.

        Parameters
        ----------
        q : array_like, shape (N, n)
            Joints, radians.

        Returns
        -------
        numpy.ndarray, shape (N, 3)
            Standard deviation of the predicted TCP's x, y, z in the world frame, metres, from
            the covariance of the estimated parameters.
        """
        k = len(self.space.robot)
        cov = tcp_position_covariance(self.robot, self.robot.check_joints(q), self.names,
                                      self.covariance[:k, :k])
        return np.sqrt(np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0))

    def parameter_table(self) -> list[dict]:
        """Every candidate parameter (and nuisance) with nominal, estimate, correction, sigma
        (display units: mm, deg; nuisance in its own)."""
        start = self.initial.robot
        sigma = dict(zip(self.unknowns, self.sigma, strict=True))
        units = dict(zip(start.parameter_names, start.parameter_units(), strict=True))
        nominal = dict(zip(start.parameter_names, start.nominal_values, strict=True))
        estimate = dict(zip(self.robot.parameter_names, self.robot.values, strict=True))
        nuisance = self.problem.nuisance_names
        dropped, held = set(self.identifiability.dropped), set(self.identifiability.undetermined)
        unused = self.not_used
        rows = []
        for name in self.identifiability.names:
            if name in nuisance:  # e.g. plane coefficients: reported in their own unit
                j = nuisance.index(name)
                unit, f = "", 1.0
                nom, est = float(self.initial.nuisance[j]), float(self.state.nuisance[j])
            else:  # a joint-error term left unidentified is not carried: its estimate is nominal
                unit, f = _DISPLAY[units[name]]
                nom, est = nominal[name] * f, estimate.get(name, nominal[name]) * f
            s = sigma.get(name)
            rows.append({"name": name, "unit": unit, "nominal": float(nom), "estimate": float(est),
                         "correction": float(est - nom), "sigma": None if s is None else float(s * f),
                         "status": "dropped" if name in dropped else
                         "not determined" if name in held else "estimated",
                         "identification": vocabulary.status(name, self.identifiability, unused)})
        return rows

    @property
    def not_used(self) -> dict[str, str]:
        """The payload / thermal parameters the calibration data cannot show (no column or one
        value), each with why (`robocal.calibration.conditions.not_used`)."""
        return conditions.not_used(self.problem.datasets, self.identifiability.dropped)

    @staticmethod
    def _observations(obs, states: tuple[State, State], weights: np.ndarray | None) -> dict:
        """The per-row section of one file (observation ``obs``): joints, measured and modelled."""
        data = obs.data
        nu = [s.nuisance[: len(obs.nuisance_names)] for s in states]  # the first file's nuisance
        measured = getattr(obs, "measured", None)
        measured = None if measured is None or measured.ndim != 2 else measured * 1e3
        if weights is not None:
            weights = weights[obs.item_of_rows()]  # one per data row
        pairs = list(zip(states, nu, strict=True))
        before, after = (obs.modelled_points(s.robot, n) * 1e3 for s, n in pairs)
        errors = [obs.position_errors(s.robot, n)[obs.item_of_rows()] * 1e3 for s, n in pairs]
        return {
            "kind": obs.kind, "error_before": errors[0].tolist(), "error_after": errors[1].tolist(),
            "pose_id": data.pose_id.tolist(), "source_row": data.source_row.tolist(),
            "smr": data.smr.tolist(),  # each joint in its unit (a quill's, a track's e1 in mm):
            "joints_deg": states[0].robot.joints_shown(data.joints).tolist(),
            "measured": None if measured is None else measured.tolist(),
            "model_before": before.tolist(), "model_after": after.tolist(),
            "weight": None if weights is None else weights.tolist(),
            "plane": None if data.plane is None else data.plane.tolist(),
        }

    def to_dict(self) -> dict:
        """The result as plain data (mm, deg), per docs/result-json.md."""
        ident, problem = self.identifiability, self.problem
        k = len(self.unknowns)
        data, first = problem.datasets[0], problem.observations[0]  # the per-row sections: the first file
        out = {
            "format": RESULT_FORMAT,
            "robocal_version": __version__,
            "provenance": self.provenance,
            "robot": self.robot.section(),
            "data": {"file": data.source, "kind": problem.kind, "n_poses": int(problem.n_poses),
                     "n_observations": int(sum(len(d) for d in problem.datasets)),
                     "files": [{"file": d.label, "kind": d.kind, "n_poses": int(d.n_poses),
                                "n_observations": len(d),
                                "sigma_mm": None if d.sigma is not None or not problem.weighted else s * 1e3}
                               for d, s in zip(problem.datasets, problem.set_sigma, strict=True)]},
            "method": self.method,
            "settings": self.settings,
            "converged": self.solver.success,
            "status": self.solver.status.value,
            "message": self.solver.message,
            "before": self.before,
            "after": self.after,
            **({"after_inliers": inliers} if (inliers := self.after_inliers) else {}),
            "parameters": self.parameter_table(),
            "dropped": vocabulary.entries(ident.dropped + ident.undetermined, ident, self.not_used),
            "priors": self._priors(),
            "identifiability": {key: v for key, v in ident.to_dict().items()
                                if key not in ("kept", "dropped", "undetermined", "confounded_with")},
            "correlation": {"names": self.unknowns,
                            "matrix": np.round(self.correlation, 6).reshape(k, k).tolist()},
            "per_file": self.per_file(),
            "per_kind": self.per_kind(),
            "rejected": self._rejected(),
            "observations": self._observations(first, (self.initial, self.state), self._first_weights()),
            "history": self.solver.history,
            "history_units": ({"cost": "1", "rms": "1 (residuals divided by sigma)"} if problem.weighted
                              else {"cost": "m^2", "rms": "m"}),
            "warnings": self.warnings,
        }
        if self.consistency is not None:
            out["consistency"] = self.consistency.to_dict()
        if self.predicted_accuracy is not None:
            out["predicted_accuracy"] = self.predicted_accuracy
        if self.nongeometric is not None:
            out["nongeometric"] = self.nongeometric
        if self.model_selection is not None:
            out["model_selection"] = self.model_selection
        if (groups := thermal_groups_of(self.robot, self.unknowns)) is not None:
            out["thermal_groups"] = groups
        if (section := conditions.section(self)) is not None:
            out["conditions"] = section
        if self.judged:
            out["validation_independence"] = [
                {"file": j.data.label, "rows": len(j.data) + j.repeated, "repeated_rows": j.repeated,
                 "rows_judged": len(j.data), "tolerance_deg": JOINT_REPEAT_TOL_DEG} for j in self.judged]
            out["data"]["validation_file"] = ", ".join(j.data.source for j in self.judged)
            out["validation_before"] = self.validation_before
            out["validation"] = self.validation
            if (shifts := self.validation_shifts) is not None:
                out["validation_shifts"] = shifts.to_dict()
            j = self.judged[0]
            out["validation_observations"] = self._observations(j.problem.observations[0], j.states, None)
        return out

    def _priors(self) -> dict:
        """The priors of the estimate (docs/priors.md): the noise scale they were weighed with and
        each parameter's 1-sigma prior in display units (mm, deg; null without a prior)."""
        space, robot = self.space, self.initial.robot
        units = dict(zip(robot.parameter_names, robot.parameter_units(), strict=True))
        names = [*space.robot, *self.identifiability.undetermined]
        sigma = dict(zip(space.names, space.prior_sigma or [np.inf] * space.size, strict=True))
        sigma.update(zip(self.identifiability.undetermined,
                         prior_sigma(robot, self.identifiability.undetermined), strict=True))
        return {"source": "robocal.identify.priors (docs/priors.md)",
                "noise": space.noise, "noise_unit": "1 (residuals divided by sigma)"
                if self.problem.weighted else "m",
                "sigma": {n: float(sigma[n] * _DISPLAY[units[n]][1]) if np.isfinite(sigma[n]) else None
                          for n in names}}

    def _first_weights(self) -> np.ndarray | None:
        """The robust weights of the first file's items."""
        w = self.solver.item_weights
        return None if w is None else w[self.problem.item_blocks()[0]]

    def _rejected(self) -> list[dict]:
        """Every row of an item a robust method rejected: its file, row, residual (mm)."""
        w = self.solver.item_weights
        if w is None:
            return []
        out = []
        for obs, items in zip(self.problem.observations, self.problem.item_blocks(), strict=True):
            item = items[obs.item_of_rows()]  # each data row's item
            for row in np.flatnonzero(w[item] == 0):
                out.append({"file": obs.data.label, "source_row": int(obs.data.source_row[row]),
                            "pose_id": int(obs.data.pose_id[row]),
                            "residual": float(self.errors[1][item[row]] * 1e3), "weight": 0.0})
        return out

    def to_json(self) -> str:
        """The result JSON text (docs/result-json.md)."""
        return json_text(self.to_dict())

    def save_json(self, path) -> None:
        """Write the result JSON (docs/result-json.md) atomically.

        Parameters
        ----------
        path : str or path-like
            The JSON file to write.
        """
        write_atomic(path, self.to_json())

    def summary(self) -> str:
        """A short human summary: before -> after, largest corrections, dropped parameters."""
        b, a = self.before, self.after
        lines = [f"{self.method}: {self.solver.message}",
                 f"calibration set ({b['n']} obs): RMS {b['rms']:.4f} -> {a['rms']:.4f} mm, "
                 f"max {b['max']:.4f} -> {a['max']:.4f} mm"]
        if self.judged:
            vb, va = self.validation_before, self.validation
            lines.append(f"validation set  ({va['n']} obs): RMS {vb['rms']:.4f} -> {va['rms']:.4f} mm, "
                         f"max {vb['max']:.4f} -> {va['max']:.4f} mm")
            if (shifts := self.validation_shifts) is not None:
                lines.append(f"  of it, a shift per validation file {shifts.shift_rms_mm:.4f} mm RMS "
                             f"(F test p = {shifts.p_value:.2g}); within the files "
                             f"{shifts.within_rms_mm:.4f} mm")
        if len(self.problem.datasets) + len(self.judged) > 1:
            for row in self.per_file():
                b, a = row["before"], row["after"]
                lines.append(f"  {row['role']} {row['kind']} {row['file'][-50:]!r} ({a['n']} obs): RMS "
                             f"{b['rms']:.4f} -> {a['rms']:.4f} mm")
        links = [r for r in self.parameter_table()
                 if r["status"] == "estimated" and block_of(r["name"]) == "links"]
        for unit in ("mm", "deg"):
            top = sorted((r for r in links if r["unit"] == unit), key=lambda r: -abs(r["correction"]))[:3]
            if top:
                lines.append(f"largest corrections ({unit}): " + ", ".join(
                    f"{r['name']} {r['correction']:+.4f} ± {r['sigma']:.4f}" for r in top))
        ident, unused = self.identifiability, self.not_used
        lines += vocabulary.lines(ident, [n for n in ident.dropped if block_of(n) != "joint_errors"]
                                  + ident.undetermined)
        if is_track_cell(self.robot):
            lines.append(TRACK_IDENTIFIABILITY)
        if self.nongeometric is not None:
            ng = self.nongeometric
            out = [n for n in ng["dropped"] if n not in unused]
            lines.append(f"non-geometric terms {', '.join(ng['terms'])}: {len(ng['kept'])} parameters "
                         f"estimated, {len(out)} left out (no effect or not separable from the geometry)")
        if self.model_selection is not None:
            lines.append(selection_table(self.model_selection))
        if (section := conditions.section(self)) is not None:
            lines += conditions.summary_lines(section)
        if len(self.rejected):
            lines.append(f"rejected observations: {len(self.rejected)}; without them the calibration "
                         f"set's RMS is {self.after_inliers['rms']:.4f} mm")
        if self.predicted_accuracy is not None:
            lines.append(accuracy_line(self.predicted_accuracy))
        lines += [f"WARNING: {w}" for w in self.warnings]
        return "\n".join(lines)


def json_text(content: dict) -> str:
    """The text of a result JSON from `CalibrationResult.to_dict` (NaN refused)."""
    return json.dumps(content, indent=1, allow_nan=False)


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


def _estimated_space(problem: CalibrationProblem, state0: State, params, rtol: float,
                     n_poses: int) -> tuple[ParameterSpace, Identifiability, list[str]]:
    """The identifiable unknowns of ``params`` (plus every nuisance parameter), their analysis, and
    warnings; IdentificationError when the data cannot support a calibration."""
    candidates = problem.space(state0.robot, params)
    J0 = problem.jacobian(state0, candidates)
    ident = analyze_jacobian(J0, candidates.names, n_poses, rtol)
    warnings = []
    if len(problem.observations) == 1:
        problem.observation.check_enough(candidates.size)
    blind = set.intersection(*(set(obs.not_observable(state0.robot)) for obs in problem.observations))
    if blind and isinstance(params, str):
        reason = "; ".join(dict.fromkeys(obs.blind_spot for obs in problem.observations if obs.blind_spot))
        warnings.append(f"{reason}: {', '.join(sorted(blind, key=state0.robot.parameter_names.index))} "
                        "are held at their nominal values")
    if ident.rank < max(1, candidates.size // 2):
        raise IdentificationError(
            f"the pose set is degenerate: only {ident.rank} of {candidates.size} parameters "
            f"are identifiable from {n_poses} poses; measure poses spread over the workspace")
    if J0.shape[0] <= ident.rank:
        raise IdentificationError(f"{J0.shape[0]} residuals cannot determine {ident.rank} identifiable "
                                  "parameters: measure more poses")
    lost = sorted(set(candidates.nuisance) - set(ident.kept))
    if lost:
        raise IdentificationError(f"the nuisance parameters {lost} are not identifiable: "
                                  "each plane needs contacts spread over its surface")
    kept = candidates.restricted(ident.kept)
    robot = state0.robot
    sigma = np.r_[prior_sigma(robot, kept.robot), np.full(len(kept.nuisance), np.inf)]
    mean = np.r_[robot.values[robot.indices(kept.robot)], state0.nuisance]
    columns = [candidates.names.index(n) for n in kept.names]
    lin = linear_analysis(J0[:, columns], problem.residuals(state0), sigma, problem.noise_guess,
                          [rows for rows, _ in problem.row_blocks()])
    held, ratio = undetermined(J0[:, columns], sigma, lin.noise)
    ident = hold(ident, J0, [kept.names[j] for j in held],
                 {n: float(q) for n, q in zip(kept.names, ratio, strict=True) if np.isfinite(q)})
    n_smr = min(max(d.n_smr for d in problem.datasets), len(robot.smr) + 1)
    ident = separate(ident, unidentifiable(robot, problem.kind, list(candidates.robot), n_smr, rtol))
    return kept.with_prior(sigma, mean, lin.noise).restricted(ident.kept), ident, warnings


def _run_solver(method: str, problem, state0: State, space: ParameterSpace, seed: int, progress,
                options: dict) -> SolverResult:
    """The method's solve, with a progress bar on a terminal when ``progress`` is True."""
    solve = get_solver(method)
    with Progress(iteration_limit(method, options), f"calibrate ({method})",
                  quiet=progress is not True) as bar:
        if progress is True:
            def progress(iteration, rms):  # noqa: E306 - the bar's callback
                bar.update(info=f"rms {rms * 1e3:.4f} mm")
        return solve(problem, state0, space, seed=seed, progress=progress or None, **options)


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


def _partners(cov: np.ndarray, names: list[str]) -> dict[str, list[str]]:
    """Per unknown: the (up to 4) others its estimate is most correlated with beyond
    `PARTNER_CORRELATION`."""
    corr = np.abs(correlation(cov))
    np.fill_diagonal(corr, 0.0)
    return {n: [names[j] for j in np.argsort(-corr[i])[:4] if corr[i, j] > PARTNER_CORRELATION]
            for i, n in enumerate(names)}


def _combined(errors: list[np.ndarray]) -> dict | None:
    """Statistics (mm) of several files' item errors (m) together; None for no file."""
    return position_stats(np.concatenate(errors)) if errors else None


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
    check_residual(result.after["rms"], result.problem.modelled_points(result.states[1]),
                   "the validation data", force=force, warnings=warnings)
    what = f"the validation data {data.label or ''}".strip()
    rows, repeated = independent(data, problem.datasets, what)
    if repeated:
        warnings.append(f"{what}: {repeated} of its {len(data)} rows repeat calibration poses (joints within "
                        f"{JOINT_REPEAT_TOL_DEG:g} {tolerance_unit(data)}): the held-out figures are "
                        f"computed on the other {len(rows)} rows only")
        result = replace(judged(rows), repeated=repeated)
    if result.after["rms"] > result.before["rms"]:
        warnings.append(f"the calibrated model is worse than the nominal on the validation data "
                        f"{data.label} ({result.before['rms']:.4g} -> {result.after['rms']:.4g} mm RMS): the "
                        "calibration does not carry over (too few or clustered poses, or validation data "
                        "from another setup)")
    return result


def _rows(robot=None, data=None, *args, **kwargs) -> int:
    """The measurement rows of a calibration's ``data`` (one set or several; 0 for what is not
    measurements: the calibration itself then refuses it)."""
    try:
        return sum(len(d) for d in data) if isinstance(data, list | tuple) else len(data)
    except TypeError:
        return 0


@memory_guard("the calibration")
@few_threads(_rows)
def calibrate(robot, data, method: str = "lsq", params="auto", validation=None, *,
              register_frames: bool = True, rtol: float = DEFAULT_RTOL, seed: int = 0,
              progress=None, nongeometric="default", force: bool = False, sigma: dict | None = None,
              warm_start: CalibrationResult | None = None, **options) -> CalibrationResult:
    """Calibrate ``robot`` (nominal model) against ``data``: Measurements, or a list of them of
    any kinds (points, poses, planes, distances) identified together in one problem, each set
    weighted by its noise (its sigma column, else ``sigma`` {kind: m}, else
    `robocal.identify.problem.KIND_SIGMA`).

    The pipeline: register the measurement frame (and SMR offsets) to the nominal model, keep the
    identifiable parameters, solve, then compute the covariance and the before/after statistics.

    Parameters
    ----------
    robot : Robot
        The nominal model.
    data : Measurements or list of Measurements
        The calibration data; several sets (of any kinds) are identified together.
    method : str, default 'lsq'
        ``'lsq'``, ``'robust'`` (outlier rejection), or another registered solver.
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
    **options
        Solver options (e.g. ``k0``, ``k1``, ``ridge`` for ``'robust'``; checked against its
        signature).

    Returns
    -------
    CalibrationResult
        The calibrated model (``result.robot``), the statistics before and after (mm), the
        parameters with their uncertainty, identifiability and warnings.

    Raises
    ------
    IdentificationError
        The data cannot support the calibration (too few poses), or an unknown method or
        solver option, or a method that cannot take the requested terms.
    PlausibilityError
        Data and model disagree beyond what real robots do (`robocal.identify.plausibility`;
        ``force=True`` turns those into warnings).
    DataError
        Invalid data (shapes, joint count, units).

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
    check_options(method, options)
    datasets, validations = _as_sets(data, "calibration"), _as_sets(validation, "validation")
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
                  rtol=rtol, seed=seed, progress=progress, force=force, sigma=sigma, options=options)
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
    result.predicted_accuracy, more = predict(result.robot, prediction(result),
                                              np.vstack([d.joints for d in result.problem.datasets]))
    result.warnings += more
    return result


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
               seed: int, progress, force: bool, sigma: dict | None, options: dict) -> CalibrationResult:
    """One calibration with the joint-error terms (and explicit parameter names) ``terms``; the
    arguments of `calibrate`."""
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
    errors0 = problem.position_errors(state0)
    check_residual(position_stats(errors0)["rms"], problem.modelled_points(state0),
                   "the calibration data (nominal model, frames fitted)", force=force, warnings=warnings)
    space, ident, more = _estimated_space(problem, state0, params, rtol, problem.n_poses)
    warnings += more
    first = state0 if warm_start is None else _warm_state(problem, warm_start, declared_start, space)
    out = _run_solver(method, problem, first, space, seed, progress, options)
    cov = _covariance(problem, out, space)
    check_corrections(state0.robot, out.state.robot, space.robot,
                      sigma=dict(zip(space.names, np.sqrt(np.maximum(np.diag(cov), 0.0)), strict=True)),
                      confounded={**_partners(cov, space.names), **ident.confounded_with}, force=force,
                      warnings=warnings)
    if not out.success:
        warnings.append(out.message)
    estimated_terms = [n for n in space.robot if block_of(n) == "joint_errors"]
    final_robot = out.state.robot.with_joint_errors(start.joint_error_names + [
        n for n in estimated_terms if n not in start.joint_error_names])
    result = CalibrationResult(
        robot=final_robot, start=start, method=method, identifiability=ident, space=space,
        covariance=cov, solver=out,
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
                    "sigma_mm": {k: v * 1e3 for k, v in (sigma or {}).items()}})
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
    warnings; PlausibilityError (``force``: a warning) when the fit is worse than nominal."""
    problem = result.problem
    result.consistency = check_fit(result.state.robot, result.start, problem.observations,
                                   problem.item_error_vectors(result.state),
                                   result.space.size, sigma=sigma, seed=seed)
    kept = slice(None) if result.solver.item_weights is None else result.solver.item_weights != 0
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
    return separate(ident, unidentifiable(robot, kind, ident.names, n_smr, rtol))


def _plain(options: dict) -> dict:
    return {k: v for k, v in options.items() if isinstance(v, str | int | float | bool)}


def load_result(path) -> dict:
    """Read a result JSON written by `CalibrationResult.save_json`, validated field by
    field (`robocal.core.schema.RESULT_SCHEMA`); DataError names the file and the field."""
    hint = "; give the JSON `robocal calibrate --json` wrote"
    if read_text(path, "result JSON file").lstrip().startswith("format: robocal-model"):
        raise DataError(f"{path} is a robot model YAML, not a result JSON{hint}")
    data = load_json(path, "result JSON file")
    if not isinstance(data, dict) or data.get("format") != RESULT_FORMAT:
        raise DataError(f"{path} is not a robocal result JSON (format {RESULT_FORMAT}){hint}")
    try:
        return validate(data, RESULT_SCHEMA)
    except DataError as exc:
        raise DataError(f"{path}: {exc}") from None
