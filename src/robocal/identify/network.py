"""The network of method ``neural`` (`robocal.identify.neural`): a one-hidden-layer BP network
from a target's pose error (mm / mrad) to structural parameter errors, and its plain-array file.

It lives apart from the training so that `robocal.identify.solvers.SolverResult` can carry one
without the solvers depending on a method.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.identify.plain_io import encode_plain, load_plain, save_plain

FORMAT = "robocal-bpnet/1"
FIELDS = ("W1", "b1", "W2", "b2")


def _sigmoid(z: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.tanh(0.5 * z))


@dataclass
class BPNetwork:
    """Weights ``W1 (h, i)``, thresholds ``b1 (h,)``, ``W2 (o, h)``, ``b2 (o,)``; output names."""

    W1: np.ndarray
    b1: np.ndarray
    W2: np.ndarray
    b2: np.ndarray
    outputs: list[str]
    inputs: int

    @classmethod
    def init(cls, n_in: int, n_hidden: int, outputs: list[str], rng: np.random.Generator) -> BPNetwork:
        """a401: every weight and threshold uniform in (0, 1)."""
        o = len(outputs)
        return cls(rng.uniform(0, 1, (n_hidden, n_in)), rng.uniform(0, 1, n_hidden),
                   rng.uniform(0, 1, (o, n_hidden)), rng.uniform(0, 1, o), list(outputs), n_in)

    def forward(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Hidden ``(N, h)`` and output ``(N, o)`` for inputs ``x (N, i)`` (mm / mrad)."""
        h = _sigmoid(x @ self.W1.T - self.b1)
        return h, h @ self.W2.T - self.b2

    def parameter_errors(self, x: np.ndarray) -> np.ndarray:
        """Structural errors ``(N, o)`` in SI units (m, rad) for pose errors ``x`` (mm / mrad)."""
        return self.forward(np.atleast_2d(np.asarray(x, float)))[1] * 1e-3

    def to_dict(self) -> dict:
        return {"format": FORMAT, "outputs": self.outputs, "inputs": self.inputs,
                "units": "inputs mm (position) and mrad (orientation); outputs mm and mrad",
                **{f: getattr(self, f).tolist() for f in FIELDS}}

    def file_content(self, path) -> str | bytes:
        """What :meth:`save` writes to ``path`` (``.json`` text or ``.npz`` bytes, plain arrays)."""
        return encode_plain(path, self.to_dict(), "BP network")

    def save(self, path) -> None:
        """Write ``.json`` or ``.npz`` (plain arrays) atomically."""
        save_plain(path, self.to_dict(), "BP network")

    @classmethod
    def load(cls, path) -> BPNetwork:
        """Read a network written by :meth:`save` (no pickle)."""
        d = load_plain(path, "BP network", FORMAT)
        outputs = [str(s) for s in np.atleast_1d(d["outputs"])]
        return cls(*(np.asarray(d[f], float) for f in FIELDS), outputs, int(d["inputs"]))
