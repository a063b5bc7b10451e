"""The uncertainty a check judges a model with: the original full calibration's, never an
offsets-only re-fit's own residual.

An offsets-only recalibration (`robocal.history.offsets`) re-identifies the joint zeros and keeps
every other parameter: its residual holds whatever the zeros cannot absorb (a bent link, a
collision's damage), so a check that took its noise from that residual would expect the damage and
call it "holds". The expected error of a check of such a model is built from the records:

- the noise per coordinate ``s`` and its degrees of freedom from the full calibration the chain
  of ``parent`` links leads back to (the first record that is not offsets-only);
- the covariance of its parameters from that calibration, except the re-identified joint zeros:
  theirs is the re-fit's ``s_r^2 (J^T J)^-1`` rescaled to the full calibration's noise,
  ``(s / s_r)^2`` times it (the re-fit's information with the noise floor the robot had), and
  uncorrelated with the others (two independent campaigns).
"""

from __future__ import annotations

import numpy as np

from robocal.core.errors import DataError


def is_offsets_only(record) -> bool:
    """Whether a calibration record is an offsets-only re-fit."""
    return bool((record.summary or {}).get("offsets_only"))


def _full_calibration(history, record):
    """The full calibration record the offsets-only ``record`` descends from (DataError when the
    history holds none)."""
    by_id = {r.id: r for r in history.entries(record.robot_id, "calibration")}
    seen, current = set(), record
    while is_offsets_only(current):
        seen.add(current.id)
        parent = by_id.get(current.parent)
        if parent is None or parent.id in seen:
            raise DataError(f"the calibration #{record.id} of robot id {record.robot_id!r} is an "
                            "offsets-only re-fit and the history holds no full calibration it descends from: "
                            "its residual is not the robot's noise floor; give the full calibration's result "
                            "JSON (--result)")
        current = parent
    return current


def _rescaled(refit: dict, noise_m: float) -> tuple[list[str], np.ndarray]:
    """The re-fit's parameter names and covariance (SI) with the noise ``noise_m`` for its own."""
    names = list(refit["names"])
    cov = np.asarray(refit["covariance"], float).reshape(len(names), len(names))
    own = float(refit["noise_m"])
    return names, cov * (noise_m / own) ** 2 if own > 0 else cov


def expected_uncertainty(history, record) -> dict:
    """The ``uncertainty`` (a record's format: names, covariance, noise_m, dof, kind) a check of the
    calibration ``record`` judges with (module docstring): ``record``'s own unless it is an
    offsets-only re-fit.

    Raises
    ------
    DataError
        An offsets-only record with no full calibration before it in ``history``.
    """
    if not is_offsets_only(record):
        return record.uncertainty
    full_record = _full_calibration(history, record)
    try:
        return _merged(full_record.uncertainty, record.uncertainty)
    except (KeyError, TypeError, ValueError, ZeroDivisionError) as exc:
        raise DataError(f"the history's calibrations #{full_record.id} and #{record.id} of robot id "
                        f"{record.robot_id!r} hold a malformed uncertainty ({exc!r}): record them again "
                        "with robocal calibrate --history") from None


def _merged(full: dict, refit: dict) -> dict:
    """The full calibration's uncertainty with the re-fit's zeros in it (module docstring)."""
    names = list(full["names"])
    cov = np.asarray(full["covariance"], float).reshape(len(names), len(names))
    refit_names, refit_cov = _rescaled(refit, float(full["noise_m"]))
    merged = names + [n for n in refit_names if n not in names]
    out = np.zeros((len(merged), len(merged)))
    out[: len(names), : len(names)] = cov
    index = [merged.index(n) for n in refit_names]
    out[index, :] = 0.0  # re-identified: the re-fit's uncertainty, independent of the rest
    out[:, index] = 0.0
    out[np.ix_(index, index)] = refit_cov
    return {**full, "names": merged, "covariance": out.tolist()}
