"""The conditions a robot works at besides its joints: each measured or commanded row's
(`Conditions`: what the joint-error and thermal terms depend on), the ones a model's payload and
thermal terms were calibrated over (`CalibratedRange`), and a warning wherever the model is used
beyond them.

`Conditions` is the one representation of a row's conditions from the data to the kinematics:
``Measurements.conditions``, ``Robot.fk(q, conditions=...)``, the identification Jacobian.

The payload term is linear in the payload's gravity moment and the thermal term in the temperature
difference: both were fitted on the payloads and temperatures the calibration recorded. A payload
twice the heaviest one measured, or a cell 15 K warmer than any measurement, is corrected by a
straight-line extrapolation nothing has checked (a real gearbox stiffens or softens with load; a
warm-up is not uniform). The model file keeps the ranges (``joint_errors.calibrated_conditions``),
and compensate, filter and evaluate say when a payload or temperature they correct for lies
beyond them by more than the margins below. Models saved without the ranges are not checked.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np

from robocal.core.errors import ModelError
from robocal.core.io import as_number

TEMPERATURE_MARGIN_K = 2.0  # a temperature this far beyond the calibrated range is an extrapolation
PAYLOAD_MARGIN_FRACTION = 0.1  # a payload beyond the calibrated masses by this share of the heaviest ...
PAYLOAD_MARGIN_KG = 0.5  # ... or by this, whichever is larger
KEY = "calibrated_conditions"  # the model file's key (under joint_errors)


@dataclass(frozen=True)
class Conditions:
    """What each of N rows was reached at besides its commanded joints ``(N, n)``; every field
    optional (None: not known, the terms that need it contribute nothing or use the model's fixed
    conditions, `robocal.kinematics.model.Robot.with_conditions`).

    Attributes
    ----------
    approach : numpy.ndarray of int, shape (N, n), optional
        Each joint's approach direction (-1, 0, +1), for a backlash term.
    travel : numpy.ndarray, shape (N, n), optional
        Each joint's signed move from the previous pose (rad; m for a prismatic joint), for a
        travel term.
    payload : numpy.ndarray, shape (N, 4), optional
        The payload carried: mass (kg), then its centre of mass x, y, z in the flange frame (m).
    temperature : numpy.ndarray, shape (N,), optional
        The arm's temperature, deg C.

    See Also
    --------
    rc.Robot.fk : Forward kinematics at the rows' conditions.
    rc.Robot.with_conditions : Fixed conditions for compensation and programs.
    rc.Measurements : Rows with their payload and temperature columns.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> conditions = rc.Conditions(temperature=np.array([20.0, 25.0]))  # deg C, one a row
    >>> conditions.rows([1]).temperature
    array([25.])
    """

    approach: np.ndarray | None = None
    travel: np.ndarray | None = None
    payload: np.ndarray | None = None
    temperature: np.ndarray | None = None

    @property
    def motion(self) -> Conditions:
        """Only the approach directions and moves: how the joints were reached, without the payload
        carried or the temperature."""
        return Conditions(self.approach, self.travel)

    def rows(self, index) -> Conditions:
        """The conditions of the rows ``index`` (a slice, indices or a mask) of every field given.

        Parameters
        ----------
        index : slice, array_like of int or bool
            The rows to keep.

        Returns
        -------
        Conditions
            The selected rows' conditions.
        """
        return Conditions(**{f.name: None if getattr(self, f.name) is None else
                             np.asarray(getattr(self, f.name))[index] for f in fields(self)})


UNKNOWN = Conditions()  # no row condition known (the default of every function taking conditions)


@dataclass(frozen=True)
class CalibratedRange:
    """The payload masses (kg) and temperatures (deg C) the calibration data covered, each as
    ``(lowest, highest)``, or None where the data recorded none."""

    payload_kg: tuple[float, float] | None = None
    temperature_c: tuple[float, float] | None = None

    def to_dict(self) -> dict:
        """Plain data for the model YAML."""
        return {name: [float(v) for v in span] for name, span in
                (("payload_kg", self.payload_kg), ("temperature_c", self.temperature_c)) if span is not None}

    @classmethod
    def from_dict(cls, data) -> CalibratedRange:
        """The range of a model file's ``calibrated_conditions`` mapping (checked)."""
        if not isinstance(data, dict) or not set(data) <= {"payload_kg", "temperature_c"}:
            raise ModelError(f"joint_errors.{KEY} must be a mapping with payload_kg and/or temperature_c: "
                             "[lowest, highest]")
        spans = {}
        for name, span in data.items():
            if not isinstance(span, list | tuple) or len(span) != 2:
                raise ModelError(f"joint_errors.{KEY}.{name} must be [lowest, highest]")
            lo, hi = (as_number(v, f"joint_errors.{KEY}.{name}", ModelError) for v in span)
            if lo > hi:
                raise ModelError(f"joint_errors.{KEY}.{name}: the lowest value {lo:g} is above the "
                                 f"highest {hi:g}")
            spans[name] = (lo, hi)
        return cls(**spans)


def range_of(recorded: Sequence[Conditions]) -> CalibratedRange:
    """The range of payload masses and temperatures the data sets' conditions ``recorded`` (their
    payloads ``(N, 4)`` kg, m and temperatures ``(N,)`` deg C; None: not recorded)."""
    masses = [np.asarray(c.payload, float)[:, 0] for c in recorded if c.payload is not None]
    temps = [np.asarray(c.temperature, float) for c in recorded if c.temperature is not None]

    def span(parts):
        if not parts:
            return None
        values = np.concatenate(parts)
        return float(values.min()), float(values.max())

    return CalibratedRange(span(masses), span(temps))


def beyond(calibrated: CalibratedRange | None, payload_kg=None, temperature_c=None,
           rows: str = "") -> list[str]:
    """Warnings for payload masses (kg) and temperatures (deg C), scalars or per-row arrays (None:
    not used), beyond ``calibrated`` by more than the margins; ``rows`` names the rows the arrays
    belong to (e.g. "rows of val.csv"). None, or a condition the calibration did not record:
    nothing to say."""
    if calibrated is None:
        return []
    out = []
    checks = (("payload", "payload", payload_kg, calibrated.payload_kg, "kg"),
              ("temperature", "thermal", temperature_c, calibrated.temperature_c, "deg C"))
    for name, term, used, span, unit in checks:
        if used is None or span is None:
            continue
        values = np.atleast_1d(np.asarray(used, float))
        lo, hi = span
        margin = TEMPERATURE_MARGIN_K if name == "temperature" else \
            max(PAYLOAD_MARGIN_KG, PAYLOAD_MARGIN_FRACTION * hi)
        outside = values[(values < lo - margin) | (values > hi + margin)]
        if not outside.size:
            continue
        if rows:
            low, high = outside.min(), outside.max()
            shown = f"{low:.4g}" if low == high else f"{low:.4g} to {high:.4g}"
            subject = f"the {name} of {outside.size} {rows} ({shown} {unit})"
        else:
            subject = f"the {name} {outside[0]:.4g} {unit}"
        out.append(f"{subject} is beyond the {lo:.4g} to {hi:.4g} {unit} the model's {term} term was "
                   f"calibrated over: its correction there is extrapolated (measure at this {name} to "
                   "check it)")
    return out
