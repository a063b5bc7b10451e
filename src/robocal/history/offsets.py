"""Offsets-only recalibration: after a motor or encoder change the joint zeros move and the rest of
the robot does not. Re-identify only the joint zeros (with the tracker frame and the SMR offsets)
from a short campaign, every other parameter of the earlier calibration kept as it is."""

from __future__ import annotations

import numpy as np

from robocal.calibration.pipeline import calibrate
from robocal.core.errors import DataError
from robocal.data.instruments import noise_of
from robocal.history.expected import expected_uncertainty
from robocal.history.record import calibration_uncertainty
from robocal.history.store import History
from robocal.kinematics.model import Robot, load_model
from robocal.kinematics.model_file import dump_model

FRAME_PARAMS = ("base.x", "base.y", "base.z", "base.rx", "base.ry", "base.rz", "tool.x", "tool.y", "tool.z")
SAME_NOMINAL_TOL = 1e-9  # m or rad: the calibrated model must carry the nominal robot's links
# a re-fit leaving more than this x the full calibration's noise per coordinate: more than the zeros moved
REFIT_FLOOR_FACTOR = 3.0


def offsets_params(robot, n_smr: int = 1) -> list[str]:
    """The unknowns of an offsets-only recalibration: every joint zero, the tracker frame and the
    SMR offsets (the zeros the frame absorbs, theta1 and theta{n} on point data, are dropped by
    the identifiability analysis as usual)."""
    return [*(f"theta{i}" for i in range(1, robot.n_joints + 1)), *FRAME_PARAMS,
            *(f"smr{k}.{c}" for k in range(1, n_smr) for c in "xyz")]


def check_same_robot(nominal, start) -> None:
    """``start`` (a calibrated model) must be a calibration of ``nominal``: same joints, same
    nominal link parameters (DataError naming both otherwise)."""
    n = nominal.n_joints
    if start.n_joints != n or not np.allclose(start.nominal[: 5 * n], nominal.nominal[: 5 * n],
                                              atol=SAME_NOMINAL_TOL, rtol=0):
        raise DataError(f"the start model ({start.name}) is not a calibration of {nominal.name}: its nominal "
                        "links differ; give the calibrated model of this robot")


def recalibrate_offsets(nominal, start, data, validation=None, *, history: str | None = None,
                        robot_id: str | None = None, **options):
    """A `robocal.calibration.result.CalibrationResult` whose robot is ``start`` (an earlier
    calibration of ``nominal``) with only its joint zeros re-identified on ``data`` (point or pose
    measurements; the tracker frame and SMR offsets fitted with them); ``validation`` and
    ``options`` as `robocal.calibrate` takes them (not ``params`` nor ``nongeometric``).

    Parameters
    ----------
    nominal : Robot
        The nominal model ``start`` was calibrated from (the same robot).
    start : Robot
        The earlier calibrated model; only its joint zeros (``theta*``) change.
    data : Measurements or list of Measurements
        Point or pose tracker measurements: joints ``(n, dof)`` rad, points ``(n, 3)`` m.
    validation : Measurements, optional
        Held-out data to report the recalibrated model's accuracy on.
    history, robot_id : str, optional
        The history holding the calibration of ``start`` (`robocal.history.store`): a re-fit
        leaving more than `REFIT_FLOOR_FACTOR` times its full calibration's noise floor is
        warned of (`refit_warnings`); without them (or without a record of ``start``), more than
        that times the instrument's noise.
    **options
        Further `robocal.calibrate` options (method, loss, ``hold_out`` ...).

    Returns
    -------
    CalibrationResult
        Its ``robot`` is ``start`` with the re-identified joint zeros; ``settings["offsets_only"]``
        is True.

    Raises
    ------
    DataError
        Models of different robots, data other than points or poses, or ``params`` /
        ``nongeometric`` among the options.

    See Also
    --------
    robocal.history.check.check_calibration : Says when offsets moved.
    rc.calibrate : A full calibration.
    robocal.history.History : Records the result.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.history.offsets import recalibrate_offsets
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> start = nominal  # an earlier calibration (here the nominal model itself)
    >>> knocked = start.with_values({"theta2": start.get("theta2") + 0.001})  # J2's zero moved 1 mrad
    >>> sim = rc.simulate_tracker(knocked, 20, noise_mm=0.01, seed=1, as_is=True)
    >>> result = recalibrate_offsets(nominal, start, sim.data)
    >>> round((result.robot.get("theta2") - start.get("theta2")) * 1e3, 2)  # mrad: found again
    1.0
    >>> result.robot.get("a2") == start.get("a2"), result.after["rms"] < 0.05  # links kept; mm
    (True, True)
    """
    sets = list(data) if isinstance(data, list | tuple) else [data]
    check_same_robot(nominal, start)
    if any(not d.spec.sees_position for d in sets):
        raise DataError("an offsets-only recalibration needs tracker data (points or poses)")
    for key in ("params", "nongeometric"):
        if key in options:
            raise DataError(f"an offsets-only recalibration chooses its own {key}")
    n_smr = max(d.n_smr for d in sets)  # held-out poses of an SMR the others lack: calibrate refuses them
    result = calibrate(start, sets, params=offsets_params(start, n_smr), validation=validation,
                       nongeometric="none", **options)
    result.settings["offsets_only"] = True
    result.warnings += refit_warnings(history, robot_id, start, result, sets)
    return result


def offsets_start(start: str | None, offsets_only: bool, params: str = "auto",
                  nongeometric: str = "default") -> Robot | None:
    """The start model of an offsets-only recalibration (``--offsets-only --start START``; None
    without them), the options that cannot go with it refused (DataError)."""
    if bool(offsets_only) != bool(start):
        raise DataError("--offsets-only and --start go together: the joint zeros of the calibrated model "
                        "--start are re-identified")
    if not offsets_only:
        return None
    if params != "auto" or nongeometric.strip().lower() != "default":
        raise DataError("--offsets-only chooses its own parameters: drop --params and --nongeometric")
    return load_model(start)


def zero_shifts(result, start) -> list[dict]:
    """The re-identified joint zeros' change from ``start`` (the earlier calibration):
    ``[{name, shift, sigma, unit}]`` in deg, largest first."""
    sigma = dict(zip(result.unknowns, result.sigma, strict=True))
    rows = [{"name": n, "unit": "deg", "shift": float(np.rad2deg(result.robot.get(n) - start.get(n))),
             "sigma": float(np.rad2deg(sigma[n]))} for n in result.names if n.startswith("theta")]
    return sorted(rows, key=lambda r: -abs(r["shift"]))


def shifts_line(shifts: list[dict]) -> str:
    """One line of `zero_shifts`: each joint zero's change with its sigma (deg)."""
    return "joint zeros changed from the start: " + \
        ", ".join(f"{r['name']} {r['shift']:+.4f} ± {r['sigma']:.4f} deg" for r in shifts)


def refit_warnings(location: str | None, robot_id: str | None, start, result, data=()) -> list[str]:
    """The warning (a list of at most one line) of an offsets-only re-fit ``result`` whose residual
    noise per coordinate exceeds :data:`REFIT_FLOOR_FACTOR` times the noise floor of the full
    calibration that ``start`` descends from in the history at ``location``
    (`robocal.history.expected`): more than the joint zeros changed. Without a history or a record
    of ``start`` in it, the floor is the instrument's documented noise of ``data`` (the
    measurements re-fitted; `robocal.data.instruments.noise_of`), and the sentence says the full
    calibration may have left as much."""
    record = None
    if location:
        with History(location) as history:
            try:
                record = history.calibration(robot_id, dump_model(start))
            except DataError:  # a start model calibrated elsewhere: the instrument's noise is the floor
                record = None
            else:
                floor = float(expected_uncertainty(history, record)["noise_m"])
    sets = list(data) if isinstance(data, list | tuple) else [data]
    if record is None:
        if not sets:
            return []
        floor = float(np.sqrt(np.mean([noise_of(d) ** 2 for d in sets])))
    own = float(calibration_uncertainty(result)["noise_m"])
    if own <= REFIT_FLOOR_FACTOR * floor:
        return []
    said = f"the offsets-only re-fit leaves {own * 1e3:.3g} mm per coordinate, {own / floor:.3g} x "
    if record is not None:
        return [said + f"the noise floor of the full calibration #{record.id} ({floor * 1e3:.3g} mm): more "
                "than the joint zeros changed (a bent link, a collision, another tool or SMR nest); the "
                "written model keeps that error: recalibrate fully"]
    return [said + f"the instrument's noise ({floor * 1e3:.3g} mm; no record of the start model's full "
            "calibration to compare with: give --history and --robot-id): more than the joint zeros "
            "changed (a bent link, a collision, another tool or SMR nest), unless the full calibration "
            "left as much; the written model keeps that error: recalibrate fully"]
