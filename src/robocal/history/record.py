"""History records built from results: a calibration (its model, figures, parameters with sigma,
the covariance a later check needs), an evaluation, and the fingerprints of the files they came
from; opening a command's history and recording in it."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.history.store import History, Record, check_robot_id, file_sha256, is_postgres, shown
from robocal.identify.space import block_of
from robocal.kinematics.model_file import dump_model

CHECKED_BLOCKS = ("links", "joint_errors")  # what a check judges: the frame and SMRs it refits


def fingerprints(files: list[tuple[str, str]]) -> list[dict]:
    """``[{file, role, sha256}]`` of ``(path, role)`` pairs (the bytes as read)."""
    return [{"file": str(path), "role": role, "sha256": file_sha256(path)} for path, role in files]


def calibration_uncertainty(result) -> dict:
    """What a check needs of a calibration: the covariance (SI) of its estimated link and
    joint-error parameters, and the noise (m, per coordinate) its residuals show with their
    degrees of freedom (rows minus unknowns), and the kind of data it came from."""
    names = result.names
    keep = [i for i, n in enumerate(names) if block_of(n) in CHECKED_BLOCKS]
    cov = result.covariance[np.ix_(keep, keep)]
    rows = int(sum(len(r) for r, _ in result.problem.row_blocks()))
    dof = max(rows - result.space.size, 1)
    noise = float(np.sqrt(np.sum(result.errors[1] ** 2) / dof))
    return {"names": [names[i] for i in keep], "covariance": cov.tolist(), "noise_m": noise, "dof": dof,
            "kind": result.problem.kind}


def calibration_record(result, robot_id: str, files: list[tuple[str, str]], parent: int | None = None,
                       **summary) -> Record:
    """The history record of a `robocal.calibration.result.CalibrationResult`; ``files``:
    ``(path, role)`` of its inputs; ``summary``: extra figures to keep (e.g. ``offsets_only``)."""
    validation = result.validation
    figures = {"method": result.method, "n_poses": int(result.problem.n_poses), "before": result.before,
               "after": result.after, "held_out_rms": None if validation is None else validation["rms"],
               "converged": bool(result.solver.success), **summary}
    parameters = [{k: row[k] for k in ("name", "unit", "estimate", "sigma")}
                  for row in result.parameter_table()]
    return Record(robot_id=robot_id, kind="calibration", model_yaml=dump_model(result.robot), summary=figures,
                  parameters=parameters, uncertainty=calibration_uncertainty(result),
                  data=fingerprints(files), parent=parent)


def open_history(location: str | None, robot_id: str | None, existing: bool = False,
                 writes: bool = True, outputs=()) -> str | None:
    """Check a command's ``--history`` and ``--robot-id`` before any work (before any output is
    written: all or none): both or neither, the robot id's form, the history opens; ``writes``:
    the command records in it, so it must be writable, a robocal history and sound (SQLite's
    integrity check), its schema created or migrated; else it is opened read-only and changed in
    nothing. ``existing``: a SQLite history must exist already (it holds what the command reads).
    ``outputs``: the files the command writes (None entries skipped); none may be the history (a
    ``--json`` naming it replaced every record with the JSON). The checked robot id (None without
    a history).

    Raises
    ------
    DataError
        One option without the other, a missing history, a bad robot id, a history that is not
        robocal's, damaged, or (``writes``) read-only or holding an unreadable calibration record
        of the robot id.
    """
    if bool(location) != bool(robot_id):
        raise DataError("--history and --robot-id go together: give both to record in a robot's history")
    if location and existing and not is_postgres(location) and not Path(location).exists():
        raise DataError(f"the history {location} does not exist")
    if not location:
        return robot_id
    robot_id = check_robot_id(robot_id)
    if not is_postgres(location):
        same = [str(o) for o in outputs if o is not None and Path(o).resolve() == Path(location).resolve()]
        if same:
            raise DataError(f"cannot write {same[0]}: it is the history (--history {location}), which would "
                            "lose every record; choose another output name")
    with History(location, readonly=not writes) as history:
        if writes:  # the calibrations a command records from are read after its outputs: check them now
            history.find_calibration(robot_id)
            history.probe_write()  # and that a record can be added, before any output is written
    return robot_id


def parent_calibration(location: str, robot_id: str, robot) -> int | None:
    """The id of the history's calibration record of ``robot`` (the same model), None when it
    holds none (a model calibrated elsewhere, or a nominal one); DataError when the history is
    damaged or one of the robot's calibration records is unreadable."""
    with History(location, readonly=True) as history:
        found = history.find_calibration(robot_id, dump_model(robot))
    return None if found is None else found.id


def evaluation_record(location: str, robot_id: str, robot, result, files: list[tuple[str, str]]) -> Record:
    """The record of an evaluation of ``robot`` (`robocal.calibration.evaluation.EvaluationResult`:
    its statistics in mm, poses, kind, whether the frame was fitted), derived from the calibration
    of the same model when the history holds one."""
    summary = {**result.statistics, "n_poses": result["n_poses"], "kind": result["kind"],
               "fit_frame": bool(result.fit_frame)}
    return Record(robot_id=robot_id, kind="evaluation", model_yaml=dump_model(robot), summary=summary,
                  data=fingerprints(files), parent=parent_calibration(location, robot_id, robot))


def record_entry(location: str, entry: Record) -> str:
    """Store ``entry`` in the history at ``location``; the line saying so."""
    with History(location) as history:
        ident = history.record(entry)
    return f"recorded {entry.kind} #{ident} of robot {entry.robot_id!r} in {shown(location)}"


def check_record(result, robot_id: str, robot, data_file: str, parent: int | None) -> Record:
    """The record of a check (`robocal.history.check.CheckResult`) of ``robot`` on ``data_file``,
    derived from the calibration record ``parent``."""
    figures = result.to_dict()
    summary = {key: figures[key] for key in ("verdict", "p_value", "n_poses", "rms_mm", "predicted_rms_mm")}
    summary["changed_parameters"] = result.changed_parameters
    if result.frame_change:  # a moved SMR or tracker: not the robot (the timeline says so)
        summary["frame_change"] = result.frame_change
    return Record(robot_id=robot_id, kind="check", model_yaml=dump_model(robot), summary=summary,
                  data=fingerprints([(data_file, "check")]), parent=parent)
