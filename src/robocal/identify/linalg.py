"""The linear step shared by the solvers: a damped / ridge least-squares solve via the SVD.

The undamped solve is the Moore-Penrose (generalized) inverse of seed 000, A+ r; numerically
it is computed from the SVD of the column-scaled Jacobian rather than the full-rank
decomposition C^T (C C^T)^-1 (B^T B)^-1 B^T, which is the same matrix but squares the
condition number. For tall, well-conditioned Jacobians (rows > 8 x columns, cond(J) < 1e4)
the SVD's singular values and right vectors come from the eigen-decomposition of the small
Gram matrix J^T J instead (squaring a condition number below 1e4 keeps 8 of 16 digits): the
same decomposition at a fraction of the cost.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GRAM_ROWS_PER_COLUMN = 8
GRAM_MAX_CONDITION = 1e8  # of J^T J


@dataclass
class ScaledSVD:
    """SVD of ``Js = J / scale`` (columns scaled to unit norm): ``s (k,)``, ``Vt (k, k)`` and,
    when computed directly, ``U (M, k)``; :meth:`project` gives ``U^T r`` either way."""

    U: np.ndarray | None
    s: np.ndarray
    Vt: np.ndarray
    scale: np.ndarray
    Js: np.ndarray

    @classmethod
    def of(cls, J: np.ndarray, scale: np.ndarray | None = None) -> ScaledSVD:
        if scale is None:
            scale = np.linalg.norm(J, axis=0)
            scale = np.where(scale > 0, scale, 1.0)
        Js = J / scale
        M, k = Js.shape
        if k and k * GRAM_ROWS_PER_COLUMN < M:
            w, V = np.linalg.eigh(Js.T @ Js)
            w, V = w[::-1], V[:, ::-1]
            if w[-1] > w[0] / GRAM_MAX_CONDITION:
                return cls(None, np.sqrt(w), V.T, scale, Js)
        U, s, Vt = np.linalg.svd(Js, full_matrices=False)
        return cls(U, s, Vt, scale, Js)

    def project(self, r: np.ndarray) -> np.ndarray:
        """``U^T r`` ``(k,)``."""
        if self.U is not None:
            return self.U.T @ r
        return (self.Vt @ (self.Js.T @ r)) / self.s

    def solve(self, r: np.ndarray, damping: float = 0.0, prior: np.ndarray | None = None,
              rcond: float = 1e-12) -> np.ndarray:
        """Minimise ||J x - r||^2 + damping ||S (x + prior)||^2 (S the column scale).

        ``damping`` is absolute in the scaled problem (0 gives the pseudo-inverse solution);
        ``prior`` (unscaled) shrinks the total ``x + prior`` instead of the step (ridge on the
        parameter errors rather than on the increment).
        """
        s = self.s
        keep = s > rcond * s[0] if s.size else s.astype(bool)
        filt = np.where(keep, s / np.where(keep, s**2 + damping, 1.0), 0.0)
        y = filt * self.project(r)
        if prior is not None and damping > 0:
            z = self.Vt @ (prior * self.scale)
            y = y - np.where(keep, damping / (s**2 + damping), 1.0) * z
        return (self.Vt.T @ y) / self.scale
