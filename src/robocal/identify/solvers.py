"""Solver registry and the output every solver returns.

A new method is one module in this package with ``solve(problem, start, names, *, seed,
progress, **options) -> SolverOutput`` and one line in ``SOLVERS``. ``progress``, when given, is
called as ``progress(iteration, rms)`` with the current (best) RMS error of one measurement item
in SI units (m for tracker points when the data carry no sigma).
"""

from __future__ import annotations

import importlib
import inspect
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


_PASSED_BY_CALIBRATE = ("seed", "progress")


def check_options(method: str, solve, options: dict) -> dict:
    """The method's options, validated against its ``solve`` signature: known names only, and
    numbers where the default is a number (int where it is an int). Raises IdentificationError."""
    params = {p.name: p for p in inspect.signature(solve).parameters.values()
              if p.kind is inspect.Parameter.KEYWORD_ONLY and p.name not in _PASSED_BY_CALIBRATE}
    unknown = sorted(set(options) - set(params))
    if unknown:
        raise IdentificationError(f"method {method!r} has no option(s) {unknown}; its options are "
                                  f"{sorted(params) or 'none'}")
    for name, value in options.items():
        default = params[name].default
        if isinstance(default, bool):
            ok = isinstance(value, bool) or value in (0, 1)
        elif isinstance(default, int):
            ok = isinstance(value, int | np.integer) and not isinstance(value, bool)
        elif isinstance(default, float):
            ok = isinstance(value, int | float | np.number) and not isinstance(value, bool) \
                and np.isfinite(value)
        else:
            ok = True  # str / None / object options are checked by the method itself
        if not ok:
            raise IdentificationError(f"option {name}={value!r} of method {method!r} must be "
                                      f"{type(default).__name__} like its default {default!r}")
    return options
