"""Learned residual: kernel ridge regression from joint configuration to the remaining error.

After the geometric (and joint-error) calibration, the position error that remains at each
measured point is regressed on joint features phi(q) = [sin q, cos q] (plus a one-hot SMR
column scaled by ``smr_weight`` so the SMRs of one tool share what they can) with a Gaussian
(RBF) kernel k(a, b) = exp(-|a - b|^2 / (2 l^2)). The ridge parameter lambda and length scale l
are chosen by k-fold cross-validation over whole poses (all SMRs of one pose in the same fold,
so the folds do not leak), which is what guards against overfitting: the chosen model is the
one that predicts held-out poses best; if none beats predicting zero, the correction is zero.
numpy/scipy only. Saved as plain arrays (npz / JSON), never pickle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from robocal.core.errors import DataError
from robocal.identify.plain_io import load_plain, save_plain

FORMAT = "robocal-residual/1"
LAMBDAS = (1e-3, 1e-2, 1e-1, 1.0, 10.0)
LENGTHS = (0.5, 1.0, 2.0)


def features(q: np.ndarray, smr: np.ndarray, n_smr: int, smr_weight: float = 1.0) -> np.ndarray:
    """Joint features ``(N, 2n + n_smr)``."""
    onehot = np.zeros((q.shape[0], n_smr))
    onehot[np.arange(q.shape[0]), np.asarray(smr, int)] = smr_weight
    return np.hstack([np.sin(q), np.cos(q), onehot])


def _kernel(A: np.ndarray, B: np.ndarray, length: float) -> np.ndarray:
    d2 = np.maximum((A**2).sum(1)[:, None] + (B**2).sum(1)[None] - 2 * A @ B.T, 0.0)
    return np.exp(-d2 / (2 * length**2))


def _fit(X, Y, lam, length):
    K = _kernel(X, X, length)
    K[np.diag_indices_from(K)] += lam
    return scipy.linalg.solve(K, Y, assume_a="pos")


@dataclass
class ResidualModel:
    """Training features ``X (N, f)``, dual coefficients ``coef (N, 3)`` (m), hyperparameters."""

    X: np.ndarray
    coef: np.ndarray
    length: float
    lam: float
    n_smr: int
    cv_rms_mm: float
    zero_rms_mm: float

    @classmethod
    def fit(cls, q: np.ndarray, smr: np.ndarray, pose_id: np.ndarray, errors: np.ndarray, *,
            folds: int = 5, seed: int = 0, lambdas=LAMBDAS, lengths=LENGTHS) -> ResidualModel:
        """Fit to measured-minus-modelled ``errors (N, 3)`` (m) at joints ``q (N, n)`` (rad)."""
        n_smr = int(np.max(smr)) + 1
        X = features(q, smr, n_smr)
        poses = np.unique(pose_id, return_inverse=True)[1]
        fold_of_pose = np.random.default_rng(seed).permutation(poses.max() + 1) % folds
        fold = fold_of_pose[poses]
        zero = float(np.sqrt(np.mean(np.sum(errors**2, axis=1))) * 1e3)
        best = (zero, None, None)
        for length in lengths:
            sq = np.zeros(len(lambdas))
            for f in range(folds):  # one eigendecomposition per fold serves every lambda
                tr, te = fold != f, fold == f
                s, V = np.linalg.eigh(_kernel(X[tr], X[tr], length))
                proj = V.T @ errors[tr]
                Kte = _kernel(X[te], X[tr], length) @ V
                for i, lam in enumerate(lambdas):
                    sq[i] += float(np.sum((errors[te] - Kte @ (proj / (s + lam)[:, None])) ** 2))
            for i, lam in enumerate(lambdas):
                rms = float(np.sqrt(sq[i] / len(errors)) * 1e3)
                if rms < best[0]:
                    best = (rms, lam, length)
        if best[1] is None:  # nothing beats zero correction on held-out folds
            return cls(X[:0], np.zeros((0, 3)), 1.0, 1.0, n_smr, zero, zero)
        return cls(X, _fit(X, errors, best[1], best[2]), best[2], best[1], n_smr, best[0], zero)

    def predict(self, q: np.ndarray, smr: np.ndarray) -> np.ndarray:
        """Predicted remaining error ``(N, 3)`` (m) at joints ``q`` with SMR indices ``smr``."""
        if not len(self.coef):
            return np.zeros((q.shape[0], 3))
        if np.max(smr, initial=0) >= self.n_smr:
            raise DataError(f"the residual model knows {self.n_smr} SMR(s); data use more")
        return _kernel(features(q, smr, self.n_smr), self.X, self.length) @ self.coef

    def to_dict(self) -> dict:
        return {"format": FORMAT, "units": "m (coef), rad-feature length scale",
                "X": self.X.tolist(), "coef": self.coef.tolist(), "length": self.length,
                "lam": self.lam, "n_smr": self.n_smr, "cv_rms_mm": self.cv_rms_mm,
                "zero_rms_mm": self.zero_rms_mm}

    def save(self, path) -> None:
        """Write ``.json`` or ``.npz`` atomically (plain arrays)."""
        save_plain(path, self.to_dict(), "residual model")

    @classmethod
    def load(cls, path) -> ResidualModel:
        """Read a model written by :meth:`save` (no pickle)."""
        d = load_plain(path, "residual model", FORMAT)
        X = np.asarray(d["X"], float)
        return cls(X.reshape(-1, X.shape[-1]) if X.size else X.reshape(0, 0),
                   np.asarray(d["coef"], float).reshape(-1, 3), float(d["length"]), float(d["lam"]),
                   int(d["n_smr"]), float(d["cv_rms_mm"]), float(d["zero_rms_mm"]))
