"""How accurate is a model on measurements: position error statistics in mm."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from robocal.calibration.cell_evaluation import evaluate_cell
from robocal.calibration.result import CalibrationResult, result_prediction
from robocal.core.errors import DataError, PlausibilityError
from robocal.core.io import write_all
from robocal.core.resources import EVALUATION_ADVICE, check_memory, evaluation_bytes
from robocal.data.csv_table import count_lines
from robocal.data.instruments import declared
from robocal.data.registration import apply_registration, register_frame
from robocal.identify.observations import observation_for
from robocal.identify.plausibility import check_joint_limits, check_residual, check_spread
from robocal.kinematics.joint_errors import extrapolated_conditions
from robocal.kinematics.workcell import Cell
from robocal.report.metrics import position_stats
from robocal.trust.consistency import check_fit
from robocal.trust.coverage import Prediction
from robocal.trust.coverage import prediction as fit_prediction
from robocal.trust.diagnosis import diagnosed, fit_rms_mm
from robocal.trust.held_out import held_out_of, judge_file


def model_errors(robot, data) -> np.ndarray:
    """Per-row errors of ``robot`` on ``data`` (m), from the data kind's observation model:
    point/pose ``(N, 3)`` measured - modelled position; plane ``(N,)`` signed distance of the
    modelled tip to the least-squares plane (of the model's tips) of its plane index; distance
    ``(N,)`` modelled - measured distance (both rows of a pair carry it)."""
    obs = _observation(robot, data)
    return _row_errors(obs, robot, obs.nuisance_start(robot))


def _observation(robot, data):
    """The observation of ``data`` for ``robot`` (checked: joints, and the SMRs of a tracker's data:
    markers' offsets are the observation's own unknowns, fitted on the data)."""
    data.check_against(robot)
    if data.spec.sees_position and data.n_smr > len(robot.smr) + 1:
        raise DataError(f"the data use {data.n_smr} SMRs but the model has {len(robot.smr) + 1}: "
                        "register the frame first (--fit-frame) or use a model with these SMRs")
    return observation_for(data, robot)


def _row_errors(obs, robot, nuisance: np.ndarray) -> np.ndarray:
    """`model_errors` of an observation with its nuisance."""
    r = obs.residuals(robot, nuisance).reshape(obs.n_items, obs.rows_per_item)
    if obs.rows_per_item > 1:
        return r[:, :3]
    return -r[obs.item_of_rows(), 0]


# The model's own frame and SMR miss the data by more than this (mm RMS) and this many times what a
# refitted frame and SMR leave: the tracker or the SMR moved since the model was made.
FRAME_MOVED_MM = 0.1
FRAME_MOVED_GAIN = 5.0


def _check_frame_moved(robot, data, rms_mm: float, warnings: list[str], frame_from=None) -> None:
    """Warn when refitting only the tracker frame and SMR offsets explains most of the error (of
    the model's own frame, or of the frame fitted on ``frame_from``: the tracker or SMR moved
    between the two files)."""
    refit = fit_rms_mm(robot, data)
    if rms_mm > FRAME_MOVED_MM and rms_mm > FRAME_MOVED_GAIN * refit:
        since = "since the model was made"
        if frame_from is not None:
            fit_on = Path(frame_from.file).name if frame_from.file else "the fit data"
            since = f"between {fit_on} and these data"
        warnings.append(f"with the tracker frame and SMR offsets refitted the model misses these data by "
                        f"{refit:.3g} mm RMS instead of {rms_mm:.3g} mm: the tracker or the SMR moved "
                        f"{since} (--fit-frame judges the links alone)")


_ERRORS = "<errors_mm>"  # stands for the per-row error list in the JSON until it is written
STATISTICS = ("n", "rms", "mean", "max", "p95")  # the statistics an evaluation reports (mm; n a count)


class EvaluationResult(dict):
    """What `evaluate` returns: the dict of statistics it always returned (``n``, ``rms``,
    ``mean``, ``max``, ``p95`` in mm, ``errors_mm``, ``kind``, ``n_poses``, ``consistency``,
    ``warnings`` ...) with the result protocol: ``summary()``, ``warnings``, ``to_dict()``,
    ``write()``. ``names`` labels the model, the data and the frame's data in the summary and the
    JSON (file names or catalog names; None: unnamed).

    Parameters
    ----------
    stats : dict
        The statistics (mm) and the warnings.
    names : dict, optional
        ``{"model": ..., "data": ..., "frame_from": ...}``: the names the summary and the JSON show.
    fit_frame : bool, default False
        The measurement frame was fitted on the data evaluated.

    See Also
    --------
    rc.evaluate : The evaluation that returns it.

    Examples
    --------
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> sim = rc.simulate_tracker(robot, 30, noise_mm=0.01, seed=1, as_is=True)
    >>> stats = rc.evaluate(robot, sim.data)
    >>> stats["rms"] < 0.05, stats.warnings == stats["warnings"]  # mm
    (True, True)
    >>> stats.summary().startswith("point errors of the model on the data (30 poses): n 30, rms")
    True
    """

    def __init__(self, stats: dict, names: dict | None = None, fit_frame: bool = False) -> None:
        super().__init__(stats)
        self.names = dict(names or {})
        self.fit_frame = bool(fit_frame)

    @property
    def warnings(self) -> list[str]:
        """What the evaluation warns of (one line each)."""
        return self["warnings"]

    @property
    def statistics(self) -> dict:
        """``{n, rms, mean, max, p95}`` (mm)."""
        return {k: self[k] for k in STATISTICS}

    def summary(self) -> str:
        """The kind of errors, of which model on which data, the statistics (mm; and of the
        rotation errors, deg, for 6-D rows); point or pose data on a second line: judged against
        the calibration's prediction, or that they are not (no ``result``).

        Returns
        -------
        str
            One line, two for point or pose data.
        """
        stats = self.statistics
        rotation = self.get("rotation_deg")
        turns = "" if rotation is None else "; rotation " + ", ".join(
            f"{k} {rotation[k]:.4f} deg" for k in ("rms", "mean", "max", "p95"))
        line = (f"{self['kind']} errors of {self.names.get('model') or 'the model'} on "
                f"{self.names.get('data') or 'the data'} ({self['n_poses']} poses): "
                + ", ".join(f"{k} {stats[k]:.4f} mm" if k != "n" else f"n {stats[k]}" for k in STATISTICS)
                + turns)
        judged = self.get("held_out")
        if judged is not None:
            return f"{line}\n{judged.line()}"
        if self.fit_frame or "error_vectors_mm" not in self:
            return line
        return (f"{line}\nnot judged against a calibration's prediction: give the calibration's result "
                "(--result RESULT.json, result=) to judge these data as calibrate judges its validation")

    def to_dict(self) -> dict:
        """The evaluation JSON: the names, the statistics, each row's error (mm), the consistency
        and the warnings.

        Returns
        -------
        dict
            The evaluation (JSON-ready).
        """
        out = {"model": self.names.get("model"), "data": self.names.get("data"), "kind": self["kind"],
               "n_poses": self["n_poses"], "fit_frame": bool(self.fit_frame),
               "frame_from": self.names.get("frame_from"), "units": "mm", "evaluation": self.statistics,
               "errors_mm": self["errors_mm"].tolist(), "consistency": self["consistency"],
               "held_out": None if self.get("held_out") is None else self["held_out"].to_dict(),
               "warnings": self["warnings"]}
        if "rotation_deg" in self:
            out["rotation_deg"] = self["rotation_deg"]
        return out

    def write(self, json_path=None) -> list[str]:
        """Write `to_dict` as JSON to ``json_path`` (atomically); the paths written.

        Parameters
        ----------
        json_path : str or pathlib.Path, optional
            The JSON file (None: nothing written).

        Returns
        -------
        list of str
            The paths written.
        """
        if json_path is None:
            return []
        out = self.to_dict()  # the per-row errors on one line by json's C encoder (indent: pure Python)
        text = json.dumps({**out, "errors_mm": _ERRORS}, indent=2)
        write_all({json_path: text.replace(f'"{_ERRORS}"', json.dumps(out["errors_mm"]), 1) + "\n"})
        return [str(json_path)]


def check_files_memory(paths) -> None:
    """Refuse, before reading them, measurement files (None entries skipped) with more rows than an
    evaluation can hold in this machine's memory (ResourceError naming what it needs)."""
    rows = sum(count_lines(p) for p in paths if p is not None)
    check_memory(evaluation_bytes(rows), f"evaluating {rows:,} measurement rows", EVALUATION_ADVICE)


def evaluate(robot, data, fit_frame: bool = False, *, frame_from=None, force: bool = False,
             names: dict | None = None, instrument: str | None = None, result=None) -> EvaluationResult:
    """Position error statistics (mm) of ``robot`` against ``data``.

    ``fit_frame`` first registers the base frame and SMR offsets on ``data`` (for a nominal
    model); ``frame_from`` (Measurements) registers them on another data set and judges ``data``
    with them (registered on a calibration set, judged on a validation set). Returns
    ``{"n", "rms", "mean", "max", "p95"}`` plus ``"errors_mm"`` (N,) per-row error magnitudes
    (plane/distance: signed), ``"error_vectors_mm"`` (N, 3) for point/pose data, ``"kind"``,
    ``"n_poses"`` and, with a fitted frame, ``"robot"`` (the registered model) and
    ``"registration_rms_mm"``, and ``"consistency"``: the residual test against the instrument's noise
    (`robocal.trust.consistency`; its warnings join ``"warnings"``). PlausibilityError when the
    model misses the data by more than a robot's errors can explain (``force=True``: a warning in
    ``"warnings"``).

    Parameters
    ----------
    robot : Robot or Cell
        The model judged (calibrated, or nominal with ``fit_frame``); a work cell
        (`robocal.kinematics.workcell.Cell`) is judged on its bodies' SMR points with one tracker
        frame fitted for all (`robocal.calibration.cell_evaluation`: returns a ``CellEvaluation``).
    data : Measurements or CellMeasurements
        The measurements it is judged on (any kind; points in the model's world frame unless a
        frame is fitted); of a cell, its rows split per body.
    fit_frame : bool, default False
        First register the base frame and SMR offsets on ``data`` (for a nominal model).
    frame_from : Measurements, optional
        Register the frame on this set instead and judge ``data`` with it.
    force : bool, default False
        Turn the plausibility errors into warnings.
    names : dict, optional
        ``{"model": ..., "data": ..., "frame_from": ...}``: how the summary and the JSON name them.
    instrument : str, optional
        The instrument that took ``data`` if it declares none (`robocal.data.instruments`): its
        documented noise is the consistency test's. Marker and camera data fit their own frames
        (capture frame and marker offsets; camera and board) on ``data`` itself.
    result : CalibrationResult or str or pathlib.Path, optional
        The calibration that made ``robot`` (its result, or the result JSON ``calibrate --json``
        wrote): point or pose data are judged against its accuracy prediction at their poses as
        ``calibrate`` judges its validation data (`robocal.trust.held_out.judge_file`, one code
        path): ``"held_out"``, its warnings in ``"warnings"``. Without it, the summary says the
        data are not judged against a prediction.

    Returns
    -------
    EvaluationResult
        A dict (as before) with ``summary()``, ``warnings``, ``to_dict()``, ``write()``:
        ``n``, ``rms``, ``mean``, ``max``, ``p95`` (mm); ``errors_mm`` ``(N,)`` (plane/distance:
        signed); ``error_vectors_mm`` ``(N, 3)`` (point/pose); ``rotation_deg`` (6-D rows: pose, camera);
        ``kind``; ``n_poses``; ``warnings`` (list of str); ``consistency`` (the residual test);
        ``held_out`` (`robocal.trust.held_out.HeldOut`, with ``result``; else None); with a fitted
        frame ``robot`` and ``registration_rms_mm``.

    Raises
    ------
    PlausibilityError
        The model misses the data by more than a robot's errors can explain (wrong robot, wrong
        units, a moved tracker).
    DataError
        Data that do not fit the model (joint count, SMR indices, joint readings beyond any
        real robot's travel).
    ResourceError
        The machine lacks the memory the evaluation needs (refused before it starts, naming how
        much it needs: `robocal.core.resources.evaluation_bytes`).

    See Also
    --------
    robocal.calibration.evaluation.EvaluationResult : What it returns.
    rc.calibrate : Calibrate, with held-out data (``validation``).
    robocal.history.check.check_calibration : Whether a calibration still holds.

    Examples
    --------
    >>> import robocal as rc
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> sim = rc.simulate_tracker(nominal, 30, noise_mm=0.01, seed=3)
    >>> rc.evaluate(nominal, sim.data, fit_frame=True)["rms"] > 0.5  # mm: the nominal model's error
    True
    >>> stats = rc.evaluate(sim.truth, sim.data)  # the true robot: only the noise is left
    >>> round(stats["rms"], 6) == round(sim.noise_floor_mm, 6), stats["error_vectors_mm"].shape
    (True, (30, 3))
    """
    if isinstance(robot, Cell):  # every body in one tracker frame (robocal.calibration.cell_evaluation)
        return evaluate_cell(robot, data)
    data = declared([data], instrument)[0]
    predicted = _prediction(result, robot)
    try:
        return EvaluationResult(_statistics(robot, data, fit_frame, frame_from, force, predicted), names,
                                fit_frame)
    except PlausibilityError as exc:  # the data's own diagnosis first when it tells more
        fitted = fit_frame or frame_from is not None
        raise diagnosed(exc, robot, [d for d in (frame_from, data) if d is not None], fitted) from None


def _prediction(result, robot) -> Prediction | None:
    """The accuracy prediction of ``result`` (a `CalibrationResult` or its JSON's path) for the
    calibrated ``robot``; None without ``result``."""
    if result is None:
        return None
    if isinstance(result, CalibrationResult):
        return fit_prediction(result)
    if not isinstance(result, str | Path):
        raise DataError(f"result: a CalibrationResult or the path of its JSON, not {type(result).__name__}")
    return result_prediction(result, robot)


def _statistics(robot, data, fit_frame: bool, frame_from, force: bool,
                predicted: Prediction | None = None) -> dict:
    """`evaluate`'s statistics as a plain dict; the data judged against ``predicted``."""
    rows = len(data) + (0 if frame_from is None else len(frame_from))
    check_memory(evaluation_bytes(rows), f"evaluating {rows:,} measurement rows", EVALUATION_ADVICE)
    out, warnings = {}, []
    for d in (data, frame_from):
        if d is not None:
            check_joint_limits(robot, d, f"the data {d.label or ''}".strip(), force=force, warnings=warnings)
    warnings += extrapolated_conditions(robot, data.conditions,
                                        f"rows of {Path(data.file).name if data.file else 'the data'}")
    if fit_frame or frame_from is not None:
        fitted_on = data if frame_from is None else frame_from
        reg = register_frame(robot, fitted_on)
        robot = apply_registration(robot, reg)
        modelled = robot.fk(fitted_on.joints, smr=fitted_on.smr, conditions=fitted_on.conditions)[:, :3, 3]
        check_spread(fitted_on.points, modelled, "the data the frame is fitted on", force=force,
                     warnings=warnings)
        out["robot"] = robot
        out["registration_rms_mm"] = reg.rms * 1e3
    obs = _observation(robot, data)
    nuisance = obs.nuisance_start(robot)
    err = _row_errors(obs, robot, nuisance)
    stats = position_stats(err)
    check_residual(stats["rms"], obs.modelled_points(robot, nuisance), "the evaluated data", force=force,
                   warnings=warnings)
    if not fit_frame and data.spec.sees_position:
        _check_frame_moved(robot, data, stats["rms"], warnings, frame_from)
    unknowns = 6 + 3 * data.n_smr if fit_frame and frame_from is None else 0
    consistency = check_fit(robot, robot, [obs], [err], unknowns)
    warnings += consistency.warnings("the model")
    stats["consistency"] = consistency.to_dict()
    stats["held_out"] = None if predicted is None or err.ndim != 2 else \
        held_out_of([judge_file(robot, predicted, data, err)], warnings)
    stats["kind"] = data.kind
    stats["n_poses"] = data.n_poses
    if err.ndim == 2:
        stats["errors_mm"] = np.linalg.norm(err, axis=1) * 1e3
        stats["error_vectors_mm"] = err * 1e3
    else:
        stats["errors_mm"] = err * 1e3
    if data.rotations is not None:  # 6-D rows (a probe, a camera): the rotation part of each residual
        r = obs.residuals(robot, nuisance).reshape(obs.n_items, 6)
        deg = np.rad2deg(np.linalg.norm(r[:, 3:] / obs.scale[3:], axis=1))
        stats["rotation_deg"] = {"rms": float(np.sqrt(np.mean(deg**2))), "mean": float(deg.mean()),
                                 "max": float(deg.max()), "p95": float(np.percentile(deg, 95))}
    stats.update(out)
    stats["warnings"] = warnings
    return stats
