"""History records built from results: a calibration (its model, figures, parameters with sigma,
the covariance a later check needs) and the fingerprints of the files it came from."""

from __future__ import annotations

import numpy as np

from robocal.history.store import Record, file_sha256
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
