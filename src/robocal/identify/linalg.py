"""The linear step shared by the solvers: a damped / ridge least-squares solve via the SVD.

The undamped solve is the Moore-Penrose (generalized) inverse of seed 000, A+ r; numerically
it is computed from the SVD of the column-scaled Jacobian rather than the full-rank
decomposition C^T (C C^T)^-1 (B^T B)^-1 B^T, which is the same matrix but squares the
condition number.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class ScaledSVD:
    """SVD of ``J / scale`` (columns scaled to unit norm): ``U (M, k)``, ``s (k,)``, ``Vt``."""

    U: np.ndarray
    s: np.ndarray
    Vt: np.ndarray
    scale: np.ndarray

    @classmethod
    def of(cls, J: np.ndarray, scale: np.ndarray | None = None) -> ScaledSVD:
        if scale is None:
            scale = np.linalg.norm(J, axis=0)
            scale = np.where(scale > 0, scale, 1.0)
        U, s, Vt = np.linalg.svd(J / scale, full_matrices=False)
        return cls(U, s, Vt, scale)

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
        y = filt * (self.U.T @ r)
        if prior is not None and damping > 0:
            z = self.Vt @ (prior * self.scale)
            y = y - np.where(keep, damping / (s**2 + damping), 1.0) * z
        return (self.Vt.T @ y) / self.scale
