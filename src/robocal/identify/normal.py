"""What a tall least-squares problem needs of its Jacobian, accumulated over chunks of rows.

A Jacobian of M rows (3 per tracker pose) and k columns costs 8 k bytes per row each time it is
held whole; the solvers, the identifiability analysis and the cross-validation folds need only
its Gram matrix ``J^T J`` (k, k) with ``J^T r`` (k,) and ``r^T r``, or its R factor (k, k) — the
triangular factor of a QR decomposition, which carries the same column geometry (norms, angles,
pivoted-QR rank decisions, singular values) as ``J`` itself because ``J = Q R`` with orthonormal
``Q``. Both are accumulated here over chunks of :data:`CHUNK_ROWS` rows, so no caller holds more
than one chunk of a derived (weighted, column-selected) copy of the rows. This module is the one
place that does it (the callers hand it the rows of each chunk).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
import scipy.linalg

CHUNK_ROWS = 3 * 4096  # residual rows per chunk (4,096 poses of 3 rows; a few MB per derived copy)



def row_chunks(n_rows: int, size: int | None = None) -> Iterator[slice]:
    """Consecutive slices of at most ``size`` (default :data:`CHUNK_ROWS`) rows covering
    ``range(n_rows)``; a single slice for ``n_rows`` 0."""
    size = CHUNK_ROWS if size is None else int(size)
    if size < 1:
        raise ValueError(f"a chunk must hold at least one row, got {size}")
    yield from (slice(s, min(s + size, n_rows)) for s in range(0, max(n_rows, 1), size))


@dataclass
class Normal:
    """The normal equations of ``min ||J x - r||^2``: ``G = J^T J`` (k, k), ``h = J^T r`` (k,),
    ``rr = r^T r`` and the number of rows."""

    G: np.ndarray
    h: np.ndarray
    rr: float
    rows: int

    @classmethod
    def zeros(cls, k: int) -> Normal:
        return cls(np.zeros((k, k)), np.zeros(k), 0.0, 0)

    def add(self, J: np.ndarray, r: np.ndarray) -> None:
        """Add the rows ``J (c, k)``, ``r (c,)``."""
        self.G += J.T @ J
        self.h += J.T @ r
        self.rr += float(r @ r)
        self.rows += J.shape[0]


def r_factor(rows: Callable[[slice], np.ndarray], n_rows: int, k: int, size: int | None = None) -> np.ndarray:
    """The R factor ``(k, k)`` (upper triangular, ``R^T R = J^T J``) of the ``n_rows x k`` matrix
    whose rows ``rows(chunk)`` gives chunk by chunk: each chunk is stacked under the R of the rows
    before it and factored again (a tall-skinny QR; as stable as the QR of the whole matrix)."""
    R = np.zeros((0, k))
    for chunk in row_chunks(n_rows, size):
        R = scipy.linalg.qr(np.vstack([R, rows(chunk)]), mode="r", check_finite=False)[0][:k]
    return np.vstack([R, np.zeros((k - R.shape[0], k))]) if R.shape[0] < k else R
