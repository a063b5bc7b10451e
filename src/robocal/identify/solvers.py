"""Solver registry and the output every solver returns.

A new method is one module in this package with ``solve(problem, start, names, *, seed,
progress, **options) -> SolverOutput`` and one line in ``SOLVERS``. ``progress``, when given, is
called as ``progress(iteration, rms)`` with the current (best) RMS error of one measurement item
in SI units (m for tracker points when the data carry no sigma).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field

import numpy as np

from robocal.errors import IdentificationError

SOLVERS = {
    "lsq": "lsq",
    "robust": "robust",
    "genetic": "genetic",
    "swarm": "swarm",
    "neural": "neural",
}


@dataclass
class SolverOutput:
    """What a solver found: the final state, per-item weights (robust), its history."""

    state: object
    converged: bool
    message: str
    history: list[dict] = field(default_factory=list)
    item_weights: np.ndarray | None = None
    extra: dict = field(default_factory=dict)


def get_solver(method: str):
    module = SOLVERS.get(method)
    if module is None:
        raise IdentificationError(f"unknown method {method!r}; choose one of {sorted(SOLVERS)}")
    return importlib.import_module(f"robocal.identify.{module}").solve
