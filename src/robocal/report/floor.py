"""The noise floor: the one figure a held-out error is compared with, in the calibration's summary,
its result JSON (``validation.noise_floor_mm``), the report's verdict and the tutorial.

A perfect model, judged on measurements it was not fitted on, still misses them by the instrument's
noise. With ``sigma_i`` the instrument's 1-sigma per coordinate on item ``i`` (the file's
``sigma_mm`` column, else the noise given per kind, else the instrument's documented noise:
:func:`robocal.trust.consistency.item_noise`) and ``d`` the coordinates of one item's error (3 for a
point or a pose's position), the expected RMS of the items' errors is::

    floor = sqrt(d * mean_i(sigma_i^2))          (mm; sqrt(3) * sigma for one instrument)

and, the noise independent of the model's own error, the model's own error is about::

    own = sqrt(max(RMS^2 - floor^2, 0))

This is the floor of the noise *model*, the same for any draw of the noise: a simulated file's own
draw of it (``robocal simulate``'s "noise drawn") scatters around it by a few percent.
"""

from __future__ import annotations

import math

import numpy as np

POINT_DIMENSIONS = 3  # coordinates of a point's (or a pose's position) error


def noise_floor_mm(sigma_mm, dimensions: int = POINT_DIMENSIONS) -> float:
    """The noise floor (mm, module docstring) of items with 1-sigma ``sigma_mm`` per coordinate (mm;
    a number, or one per item ``(N,)``) and ``dimensions`` coordinates per item's error.

    >>> round(noise_floor_mm(0.02), 5)
    0.03464
    """
    s = np.asarray(sigma_mm, dtype=float)
    if s.size == 0 or not np.all(np.isfinite(s)) or np.any(s < 0):
        raise ValueError(f"the noise must be finite and >= 0 mm, got {sigma_mm!r}")
    return float(math.sqrt(dimensions * float(np.mean(s**2))))


def own_error_mm(rms_mm: float, floor_mm: float) -> float:
    """The model's own error (mm) in a held-out RMS ``rms_mm`` that includes the noise floor
    ``floor_mm`` (module docstring); 0 when the RMS is within the floor.

    >>> round(own_error_mm(0.05, 0.03), 6)
    0.04
    """
    return math.sqrt(max(float(rms_mm) ** 2 - float(floor_mm) ** 2, 0.0))


def of_result(result: dict) -> float | None:
    """The noise floor (mm) of a result JSON's held-out figure: ``validation.noise_floor_mm``; a
    result written before that field: the calibration's noise per coordinate
    (``consistency.noise_mm``) as a point floor; None without either."""
    val = result.get("validation") or {}
    if "noise_floor_mm" in val:
        floor = val["noise_floor_mm"]
        return None if floor is None else float(floor)
    noise = (result.get("consistency") or {}).get("noise_mm")
    return None if noise is None else noise_floor_mm(float(noise))
