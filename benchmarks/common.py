"""Error measures shared by the benchmarks (mm, against a known true robot)."""

from __future__ import annotations

import numpy as np

from robocal.data.registration import umeyama


def model_error_mm(model, truth, q: np.ndarray) -> float:
    """3-D RMS (mm) of ``model``'s TCP against ``truth``'s at joints ``q (N, n)`` (noise free)."""
    e = model.fk(q)[:, :3, 3] - truth.fk(q)[:, :3, 3]
    return float(np.sqrt(np.mean(np.sum(e**2, axis=1))) * 1e3)


def rigid_error_mm(model, truth, q: np.ndarray) -> float:
    """As :func:`model_error_mm` after the best rigid motion of ``model``'s TCP positions onto
    ``truth``'s (what is left once a frame is set)."""
    p, t = model.fk(q)[:, :3, 3], truth.fk(q)[:, :3, 3]
    T = umeyama(p, t)
    return float(np.sqrt(np.mean(np.sum((p @ T[:3, :3].T + T[:3, 3] - t) ** 2, axis=1))) * 1e3)
