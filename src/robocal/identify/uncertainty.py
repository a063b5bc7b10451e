"""Parameter uncertainty: covariance s0^2 (J^T W J)^-1 on the identifiable set.

s0^2 = r^T W r / (M - k) is the a-posteriori variance factor, so the figures hold whether or
not the data gave per-point sigma. Propagated to the predicted TCP position anywhere.
"""

from __future__ import annotations

import numpy as np

from robocal.identify.linalg import ScaledSVD


def covariance(J: np.ndarray, r: np.ndarray, n_rows: int | None = None) -> np.ndarray:
    """Covariance ``(k, k)`` of the estimate from the weighted Jacobian ``(M, k)`` and
    weighted residuals ``(M,)`` at the solution; ``n_rows`` counts the rows that carry
    information (default M; fewer when a robust fit gave some zero weight)."""
    M, k = J.shape
    dof = max((M if n_rows is None else n_rows) - k, 1)
    s0_sq = float(r @ r) / dof
    svd = ScaledSVD.of(J)
    inv_s = np.where(svd.s > 1e-12 * svd.s[0], 1.0 / svd.s, 0.0)
    V = svd.Vt.T * inv_s
    return s0_sq * (V @ V.T) / np.outer(svd.scale, svd.scale)


def correlation(cov: np.ndarray) -> np.ndarray:
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    sd = np.where(sd > 0, sd, 1.0)
    return cov / np.outer(sd, sd)


def tcp_position_covariance(robot, q: np.ndarray, names, cov: np.ndarray) -> np.ndarray:
    """Covariance ``(N, 3, 3)`` (m^2) of the predicted TCP position at joints ``q (N, n)``."""
    J = robot.jacobian(q, names, kind="point")
    return np.einsum("nik,kl,njl->nij", J, cov, J)
