"""Solver registry and the one result type every solver returns.

A new method is one module in this package with ``solve(problem, start, space, *, seed,
progress, **options) -> SolverResult`` and one line in ``SOLVERS`` (the module and the name of
its iteration-limit option, which sizes the progress bar). ``progress``, when given, is called
as ``progress(iteration, rms)`` with the current (best) RMS error of one measurement item in the
residuals' unit (m for tracker points when the data carry no sigma).
"""

from __future__ import annotations

import importlib
import inspect
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from robocal.core.damped_least_squares import SUCCESS, Status
from robocal.core.errors import IdentificationError
from robocal.identify.network import BPNetwork
from robocal.identify.space import State


class SolverSpec(NamedTuple):
    """A registered method: its module in robocal.identify and its iteration-limit option."""

    module: str
    limit_option: str


SOLVERS = {
    "lsq": SolverSpec("lsq", "max_iter"),
    "robust": SolverSpec("robust", "max_outer"),
    "genetic": SolverSpec("genetic", "generations"),
    "swarm": SolverSpec("swarm", "iterations"),
    "neural": SolverSpec("neural", "epochs"),
}


@dataclass
class SolverResult:
    """What every method returns (in the spirit of scipy's ``OptimizeResult``).

    ``status`` says which stop happened and ``success`` whether it is the stopping rule the user
    asked for (convergence, or the error threshold); ``nit`` counts iterations (generations,
    epochs); ``history`` has one entry per iteration with the same keys for every method:
    ``iteration`` (int), ``cost`` (the weighted sum of squared residuals) and ``rms`` (the RMS
    error of one measurement item, the residuals' unit). Method-specific outputs are named
    fields: ``item_weights`` (robust: the final IGG3 weight of every item) and ``network``
    (neural: the trained BP network).
    """

    state: State
    status: Status
    message: str
    nit: int
    history: list[dict] = field(default_factory=list)
    item_weights: np.ndarray | None = None
    network: BPNetwork | None = None

    @property
    def success(self) -> bool:
        return self.status in SUCCESS


def history_entry(iteration: int, cost: float, n_items: int) -> dict:
    """One history entry (the keys every method uses)."""
    return {"iteration": int(iteration), "cost": float(cost),
            "rms": float(np.sqrt(cost / max(n_items, 1)))}


def get_solver(method: str):
    spec = SOLVERS.get(method)
    if spec is None:
        raise IdentificationError(f"unknown method {method!r}; choose one of {sorted(SOLVERS)}")
    return importlib.import_module(f"robocal.identify.{spec.module}").solve


def iteration_limit(method: str, options: dict) -> int | None:
    """The iteration limit the method will use with ``options`` (for a progress bar)."""
    solve = get_solver(method)
    name = SOLVERS[method].limit_option
    value = options.get(name, inspect.signature(solve).parameters[name].default)
    return int(value) if value is not None else None


_PASSED_BY_CALIBRATE = ("seed", "progress")


def check_options(method: str, options: dict) -> dict:
    """The method's options, validated against its ``solve`` signature: known names only, and
    numbers where the default is a number (int where it is an int). Raises IdentificationError."""
    solve = get_solver(method)
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
