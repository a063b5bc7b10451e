"""The result of a calibration (`CalibrationResult`, each judged data set a `Judged`), its JSON
(docs/result-json.md) and the reading of a result JSON back (`load_result`)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.calibration import conditions
from robocal.calibration.model_selection import selection_table
from robocal.core.errors import DataError, IdentificationError
from robocal.core.io import load_json, read_text, write_all, write_atomic
from robocal.core.schema import RESULT_SCHEMA, validate
from robocal.core.version import __version__
from robocal.data.measurements import Measurements
from robocal.identify import vocabulary
from robocal.identify.identifiability import Identifiability
from robocal.identify.priors import PriorScales, prior_sigma
from robocal.identify.problem import CalibrationProblem
from robocal.identify.solvers import SolverResult
from robocal.identify.space import ParameterSpace, State, block_of
from robocal.identify.uncertainty import correlation, tcp_position_covariance
from robocal.kinematics.cell import first_joint_identifiability
from robocal.kinematics.model_file import dump_model
from robocal.kinematics.thermal import groups_of as thermal_groups_of
from robocal.kinematics.transforms import matrix_to_rotvec
from robocal.report.floor import noise_floor_mm, own_error_mm
from robocal.report.metrics import position_stats
from robocal.trust.consistency import Consistency, item_noise
from robocal.trust.coverage import Prediction, accuracy_line
from robocal.trust.file_shifts import FileShifts, pose_means, split_by_file
from robocal.trust.held_out import HeldOut
from robocal.trust.provenance import JOINT_REPEAT_TOL_DEG

RESULT_FORMAT = "robocal-result/1"
NETWORK_SUFFIXES = (".npz", ".json")  # the files a trained network is written in
FRAME_LINES = 8  # an instrument's estimated frames and marker offsets shown in the summary, at most
LEANING_SHOWN = 8  # parameters leaning on their prior named in the summary, at most
PRIOR_SHARE_SHOWN = 0.1  # an estimate whose prior carries this share of its information is listed
_DISPLAY = {"m": ("mm", 1e3), "rad": ("deg", 180.0 / np.pi), "rad/m": ("deg/m", 180.0 / np.pi),
            "rad/rad": ("mdeg/deg", 1e3), "1": ("ppm", 1e6),  # "1": a scale (dimensionless)
            "rad/(kg m)": ("deg/(kg m)", 180.0 / np.pi), "rad/kg": ("deg/kg", 180.0 / np.pi),
            "1/K": ("1e-6/K", 1e6)}


def _combined(errors: list[np.ndarray]) -> dict | None:
    """Statistics (mm) of several files' item errors (m) together; None for no file."""
    return position_stats(np.concatenate(errors)) if errors else None


def check_network_output(network, method: str) -> None:
    """Refuse a file for the trained network (``network``, a path or None) unless ``method`` is
    the neural one, which trains it, and the name ends in .npz or .json; the CLI asks before the
    work, :meth:`CalibrationResult.write` again.

    Raises
    ------
    IdentificationError
        ``network`` is given with another method or file suffix.
    """
    if network and (method != "neural" or not str(network).lower().endswith(NETWORK_SUFFIXES)):
        raise IdentificationError("a network file (--network-out) needs the neural method (--method neural) "
                                  "and a .npz or .json file name")


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
    variance_components : list of Components
        Per 6-D set whose weights were estimated: its position and rotation noise
        (`robocal.identify.variance_components`).
    provenance : dict
        Versions, date and input files.
    prior_scales : PriorScales or None
        The prior scale of each parameter group the fit used (class default, estimated from the
        data, or given) and what the data ask for (`robocal.identify.priors.fit_priors`).
    consistency : Consistency or None
        The residual test of the fit (`robocal.trust.consistency`): its verdict and p-value.
    predicted_accuracy : dict or None
        The accuracy predicted over the workspace (mm) from the covariance.
    error_model_choice : str or None
        Why the default error model is the geometric one, when it is.
    held_out : HeldOut or None
        The validation files judged against the prediction (`robocal.trust.held_out`).

    See Also
    --------
    rc.calibrate : The calibration that returns it.
    rc.evaluate : Evaluate the calibrated model on other data.
    robocal.report.html.write_report : Its HTML report.
    robocal.history.History : Record it in the robot's history.

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
    variance_components: list = field(default_factory=list)  # per 6-D set (identify.variance_components)
    error_model_choice: str | None = None  # why the default error model is geometric, when it is
    prior_scales: PriorScales | None = None  # the prior group scales used and where they came from
    held_out: HeldOut | None = None  # the validation judged against the prediction (trust.held_out)

    @property
    def state(self) -> State:
        """The final state of the solver (calibrated model and nuisance)."""
        return self.solver.state

    @property
    def instrument_frames(self) -> list[dict]:
        """Per measurement set with frames of its own (a camera and its board; a capture frame and
        marker offsets): ``{"data": label, "frames": {name: {"xyz_mm", "quaternion_wxyz",
        "rotation_deg", "axis"}}}`` (an offset: ``xyz_mm`` only), the estimates of this calibration."""
        return [{"data": label, "frames": {name: _frame_dict(T) for name, T in frames.items()}}
                for label, frames in self.problem.instrument_frames(self.state)]

    @property
    def names(self) -> list[str]:
        """The estimated robot parameters."""
        return list(self.space.robot)

    @property
    def unknowns(self) -> list[str]:
        """Every estimated unknown (robot parameters, then nuisance)."""
        return self.space.names

    @property
    def notes(self) -> list[str]:
        """What the calibration data record that the calibrated model has no term for (one line
        per data set that does)."""
        return [note for note in (d.unused_conditions(self.robot) for d in self.problem.datasets) if note]

    @property
    def validation_before(self) -> dict | None:
        """Statistics (mm) of every validation item with the start model (all files together)."""
        return _combined([j.errors[0] for j in self.judged])

    @property
    def validation(self) -> dict | None:
        """Statistics (mm) of every validation item with the calibrated model (all files)."""
        return _combined([j.errors[1] for j in self.judged])

    @property
    def noise_floor_mm(self) -> float | None:
        """The noise floor of the validation figure (mm, `robocal.report.floor`): the RMS a
        perfect model would show on the validation items, from their instrument noise; None
        without validation sets, or when they are not all point or pose files (whose items are
        3-D position errors)."""
        if not self.judged or not all(j.data.spec.sees_position for j in self.judged):
            return None
        given = {k: v * 1e-3 for k, v in (self.provenance.get("sigma_mm") or {}).items()}
        sigma = [item_noise(j.data, obs.kind, len(obs.item_of_rows()), obs.item_of_rows(), given)
                 for j in self.judged for obs in j.problem.observations]
        return noise_floor_mm(np.concatenate(sigma) * 1e3)

    @property
    def validation_shifts(self) -> FileShifts | None:
        """The held-out error split into a shift per validation file and the error within the files
        (`robocal.trust.file_shifts`; point and pose files), with two validation files or more."""
        files = [j for j in self.judged if j.data.spec.sees_position]
        errors = [pose_means(j.problem.item_error_vectors(j.states[1])[0], j.data.pose_id) for j in files]
        return split_by_file([j.data.label for j in files], errors)

    def _files(self) -> list[tuple[str, Measurements, np.ndarray, np.ndarray]]:
        """(role, data, errors before, errors after) of every file, calibration then validation."""
        before, after = self.errors
        return [("calibration", data, before[items], after[items])
                for data, items in zip(self.problem.datasets, self.problem.item_blocks(), strict=True)] + \
            [("validation", j.data, *j.errors) for j in self.judged]

    def per_file(self) -> list[dict]:
        """Per measurement file (calibration, then validation): its kind and its statistics (mm)
        before and after; the errors of each kind are in mm (position, plane deviation, distance).

        Returns
        -------
        list of dict
            One a file: its name, role, kind and statistics (mm).

        Examples
        --------
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> data = rc.simulate_tracker(robot, 30, noise_mm=0.01, seed=1).data
        >>> calibration, validation = data.split_poses(0.7, seed=0)
        >>> result = rc.calibrate(robot, calibration, validation=validation)
        >>> [(f["role"], f["kind"]) for f in result.per_file()]
        [('calibration', 'point'), ('validation', 'point')]
        >>> result.per_file()[1]["after"]["rms"] < 0.05  # mm, on the held-out poses
        True
        """
        return [{"role": role, "file": data.label, "kind": data.kind, "before": position_stats(before),
                 "after": position_stats(after)} for role, data, before, after in self._files()]

    def per_kind(self) -> dict[str, dict]:
        """Per role and kind (e.g. ``calibration plane``): statistics (mm) after calibration.

        Returns
        -------
        dict of str to dict
            ``{"role kind": statistics}``.
        """
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
        (display units: mm, deg; nuisance in its own).

        Returns
        -------
        list of dict
            One a parameter (mm, deg).

        Examples
        --------
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> data = rc.simulate_tracker(robot, 30, noise_mm=0.01, seed=1).data
        >>> calibration, validation = data.split_poses(0.7, seed=0)
        >>> result = rc.calibrate(robot, calibration, validation=validation)
        >>> row = result.parameter_table()[0]
        >>> row["name"], row["unit"], row["status"]  # alpha1 turns the first axis: not identifiable
        ('alpha1', 'deg', 'dropped')
        """
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
        """The result as plain data (mm, deg), per docs/result-json.md.

        Returns
        -------
        dict
            The result (JSON-ready).
        """
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
        if self.variance_components:
            out["variance_components"] = [c.to_dict() for c in self.variance_components]
        if frames := self.instrument_frames:
            out["instrument_frames"] = frames
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
            out["validation"] = {**self.validation, "noise_floor_mm": self.noise_floor_mm}
            if (shifts := self.validation_shifts) is not None:
                out["validation_shifts"] = shifts.to_dict()
            if self.held_out is not None:
                out["held_out"] = self.held_out.to_dict()
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
        scales = {} if self.prior_scales is None else self.prior_scales.to_dict()
        return {"source": "robocal.identify.priors (docs/priors.md)", **scales,
                "leaning": self.leaning_on_prior(),
                "noise": space.noise, "noise_unit": "1 (residuals divided by sigma)"
                if self.problem.weighted else "m",
                "sigma": {n: float(sigma[n] * _DISPLAY[units[n]][1]) if np.isfinite(sigma[n]) else None
                          for n in names}}

    def leaning_on_prior(self) -> dict[str, float]:
        """The estimated parameters whose prior carries at least `PRIOR_SHARE_SHOWN` of their
        information (posterior / prior variance: how much the prior holds them), largest first;
        the parameters held near nominal are listed with the not determined ones.

        Returns
        -------
        dict of str to float
            ``{parameter: share of its information the prior carries}``, largest first.
        """
        ratio = self.identifiability.prior_ratio
        share = {n: float(ratio[n] ** 2) for n in self.space.robot if n in ratio and np.isfinite(ratio[n])}
        return dict(sorted(((n, v) for n, v in share.items() if v >= PRIOR_SHARE_SHOWN), key=lambda t: -t[1]))

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
        """The result JSON text (docs/result-json.md).

        Returns
        -------
        str
            The JSON text.
        """
        return json_text(self.to_dict())

    def save_json(self, path) -> None:
        """Write the result JSON (docs/result-json.md) atomically.

        Parameters
        ----------
        path : str or path-like
            The JSON file to write.
        """
        write_atomic(path, self.to_json())

    def write(self, output=None, json_path=None, report=None, network=None, force: bool = False) -> list[str]:
        """Write the calibrated model YAML (``output``), the result JSON (``json_path``), the HTML report
        (``report``) and the trained network of the neural method (``network``, .npz or .json):
        all computed first, then written together (all or none, `robocal.core.io.write_all`).

        Parameters
        ----------
        output, json_path, report, network : str or path-like, optional
            The files to write; None skips one.
        force : bool
            Write the results of a solve that did not converge.

        Returns
        -------
        list of str
            The paths written, in the order above.

        Raises
        ------
        IdentificationError
            The solver did not converge and ``force`` is False, or ``network`` is given for a
            method that trains none (`check_network_output`): nothing is written.

        Examples
        --------
        >>> result.write(output="calibrated.yaml", json_path="result.json")  # doctest: +SKIP
        ['calibrated.yaml', 'result.json']
        """
        if not self.solver.success and not force:
            raise IdentificationError(f"the solver did not converge ({self.solver.status.value}): nothing "
                                      "written; adjust the method's options, or rerun with --force to write "
                                      "the results anyway")
        check_network_output(network, self.method)
        texts = {}
        if output:
            texts[output] = dump_model(self.robot)
        content = self.to_dict() if json_path or report else None
        if json_path:
            texts[json_path] = json_text(content)
        if report:
            from robocal.report.html import render_report

            texts[report] = render_report(content)
        if network:
            texts[network] = self.solver.network.file_content(network)
        write_all(texts)
        return [str(path) for path in texts]

    def summary(self) -> str:
        """A short human summary: before -> after, largest corrections, dropped parameters, the
        warnings, the `notes` and why the default error model is the geometric one.

        Returns
        -------
        str
            The summary text.
        """
        b, a = self.before, self.after
        lines = [f"{self.method}: {self.solver.message}",
                 f"calibration set ({b['n']} obs): RMS {b['rms']:.4f} -> {a['rms']:.4f} mm, "
                 f"max {b['max']:.4f} -> {a['max']:.4f} mm"]
        if self.judged:
            vb, va = self.validation_before, self.validation
            lines.append(f"validation set  ({va['n']} obs): RMS {vb['rms']:.4f} -> {va['rms']:.4f} mm, "
                         f"max {vb['max']:.4f} -> {va['max']:.4f} mm")
            if (floor := self.noise_floor_mm) is not None:
                lines.append(f"  against a noise floor of {floor:.4f} mm (the instrument alone): the model's "
                             f"own error is about {own_error_mm(va['rms'], floor):.4f} mm")
            if (shifts := self.validation_shifts) is not None:
                lines.append(f"  of it, a shift per validation file {shifts.shift_rms_mm:.4f} mm RMS "
                             f"(F test p = {shifts.p_value:.2g}); within the files "
                             f"{shifts.within_rms_mm:.4f} mm")
            if self.held_out is not None:
                lines.append(f"  {self.held_out.line()}")
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
        if self.prior_scales is not None:
            lines.append(self.prior_scales.sentence())
        if leaning := self.leaning_on_prior():
            shares = ", ".join(f"{n} {v:.0%}" for n, v in list(leaning.items())[:LEANING_SHOWN])
            lines.append(f"estimated but leaning on their prior (its share of their information): {shares}")
        ident, unused = self.identifiability, self.not_used
        lines += vocabulary.lines(ident, [n for n in ident.dropped if block_of(n) != "joint_errors"]
                                  + ident.undetermined)
        if first := first_joint_identifiability(self.start):
            lines.append(first)
        if self.nongeometric is not None:
            ng = self.nongeometric
            out = [n for n in ng["dropped"] if n not in unused]
            lines.append(f"non-geometric terms {', '.join(ng['terms'])}: {len(ng['kept'])} parameters "
                         f"estimated, {len(out)} left out (no effect or not separable from the geometry)")
        if self.model_selection is not None:
            lines.append(selection_table(self.model_selection))
        lines += [c.line() for c in self.variance_components]
        lines += [_frame_line(name, frame) for f in self.instrument_frames
                  for name, frame in f["frames"].items()][:FRAME_LINES]
        if (section := conditions.section(self)) is not None:
            lines += conditions.summary_lines(section)
        if len(self.rejected):
            lines.append(f"rejected observations: {len(self.rejected)}; without them the calibration "
                         f"set's RMS is {self.after_inliers['rms']:.4f} mm")
        if self.predicted_accuracy is not None:
            lines.append(accuracy_line(self.predicted_accuracy))
        lines += [f"WARNING: {w}" for w in self.warnings]
        lines += [f"note: {note}" for note in self.notes]
        if self.error_model_choice:
            lines.append(f"error model: {self.error_model_choice}")
        return "\n".join(lines)


def json_text(content: dict) -> str:
    """The text of a result JSON from `CalibrationResult.to_dict` (NaN refused)."""
    return json.dumps(content, indent=1, allow_nan=False)


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


def result_prediction(path, calibrated) -> Prediction:
    """The accuracy prediction (`robocal.trust.coverage.Prediction`) of the result JSON ``path``,
    checked against the ``calibrated`` model (the same parameters).

    Raises
    ------
    DataError
        The JSON has no prediction or belongs to another model.
    """
    section = load_result(path).get("predicted_accuracy")
    if not isinstance(section, dict) or not isinstance(section.get("model"), dict):
        raise DataError(f"{path} has no predicted_accuracy section: calibrate again with --json to get one")
    prediction = Prediction.from_dict(section["model"])
    prediction.error_mm(calibrated, calibrated.limits.mean(axis=1)[None])  # DataError: another model's
    return prediction


def _frame_dict(T: np.ndarray) -> dict:
    """A 4 x 4 frame (m) as translation (mm), unit quaternion (w, x, y, z), rotation angle (deg) and
    axis; a ``(3,)`` offset (m) as its translation only."""
    T = np.asarray(T, float)
    if T.shape == (3,):
        return {"xyz_mm": (T * 1e3).tolist()}
    rv = matrix_to_rotvec(T[:3, :3])
    angle = float(np.linalg.norm(rv))
    quat = Rotation.from_matrix(T[:3, :3]).as_quat()  # x, y, z, w
    axis = rv / angle if angle > 0 else np.eye(3)[2]
    return {"xyz_mm": (T[:3, 3] * 1e3).tolist(), "quaternion_wxyz": [float(quat[3]), *map(float, quat[:3])],
            "rotation_deg": float(np.rad2deg(angle)), "axis": axis.tolist()}


def _frame_line(name: str, frame: dict) -> str:
    """One summary line of an instrument's estimated frame or offset (`_frame_dict`)."""
    xyz = ", ".join(f"{v:.3f}" for v in frame["xyz_mm"])
    turn = ""
    if "axis" in frame:
        axis = ", ".join(f"{v:.4f}" for v in frame["axis"])
        turn = f"; rotation {frame['rotation_deg']:.4f} deg about ({axis})"
    return f"{name}: x, y, z {xyz} mm{turn}"
