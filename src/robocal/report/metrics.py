"""Position error statistics (reports show mm)."""

from __future__ import annotations

import numpy as np

from robocal.core.errors import DataError


def position_stats(errors) -> dict:
    """Statistics in mm of position errors given in m: vectors ``(N, 3)`` or norms ``(N,)``.

    Returns ``{"n", "rms", "mean", "max", "p95"}``; ``rms`` is sqrt(mean |e|^2), ``p95`` the 95th
    percentile of |e| (linear interpolation).
    """
    e = np.asarray(errors, dtype=float)
    if e.ndim == 2 and e.shape[1] == 3:
        e = np.linalg.norm(e, axis=1)
    elif e.ndim != 1:
        raise DataError(f"position errors must be (N, 3) vectors or (N,) norms, got shape {e.shape}")
    if e.size == 0:
        raise DataError("no position errors to summarise: the data set is empty")
    if not np.isfinite(e).all():
        raise DataError("position errors contain NaN or infinite values")
    e = np.abs(e) * 1e3
    return {"n": int(e.size), "rms": float(np.sqrt(np.mean(e**2))), "mean": float(e.mean()),
            "max": float(e.max()), "p95": float(np.percentile(e, 95))}
