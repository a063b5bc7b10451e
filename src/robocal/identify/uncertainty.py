"""Parameter uncertainty: covariance s0^2 (J^T W J + P)^-1 on the estimated set, P the priors'
pseudo-observations (their weights squared on the diagonal; 0 without priors).

s0^2 = r^T W r / (M - k) is the a-posteriori variance factor, so the figures hold whether or
not the data gave per-point sigma. Propagated to the predicted TCP position anywhere.
"""

from __future__ import annotations

import numpy as np

from robocal.identify.priors import posterior_covariance


def covariance(J: np.ndarray, r: np.ndarray, n_rows: int | None = None,
               prior_weight: np.ndarray | None = None) -> np.ndarray:
    """Covariance ``(k, k)`` of the estimate from the weighted Jacobian ``(M, k)`` and
    weighted residuals ``(M,)`` at the solution; ``n_rows`` counts the rows that carry
    information (default M; fewer when a robust fit gave some zero weight); ``prior_weight``
    ``(k,)`` the prior rows' weights (0: none)."""
    M, k = J.shape
    dof = max((M if n_rows is None else n_rows) - k, 1)
    weight = np.zeros(k) if prior_weight is None else np.asarray(prior_weight, float)
    return posterior_covariance(J, weight, float(np.sqrt(float(r @ r) / dof)))


def correlation(cov: np.ndarray) -> np.ndarray:
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    sd = np.where(sd > 0, sd, 1.0)
    return cov / np.outer(sd, sd)


def tcp_position_covariance(robot, q: np.ndarray, names, cov: np.ndarray) -> np.ndarray:
    """Covariance ``(N, 3, 3)`` (m^2) of the predicted TCP position at joints ``q (N, n)``."""
    J = robot.jacobian(q, names, kind="point")
    return (J @ cov) @ J.transpose(0, 2, 1)  # not einsum's unoptimised three-operand loop
