"""Which implementation runs the hot kernels (forward kinematics of one robot, closed-form IK).

numpy is always there; numba compiles faster twins of these kernels when the optional ``fast``
extra is installed (``pip install 'robocal[fast]'``). The choice is automatic (numba when it can be
imported) and can be forced either way, for tests and comparisons, by the environment variable
``ROBOCAL_KERNELS`` (``auto``, ``numpy`` or ``numba``) or by :func:`use_kernels`. Both give the
same results to rounding (the tests check them against each other).
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Iterator
from contextlib import contextmanager
from types import ModuleType

from robocal.errors import RobocalError

ENV = "ROBOCAL_KERNELS"
CHOICES = ("auto", "numpy", "numba")
_forced: str | None = None  # set by use_kernels, wins over the environment
_loaded: dict[str, ModuleType | None] = {}


def _choice() -> str:
    choice = _forced or os.environ.get(ENV, "").strip().lower() or "auto"
    if choice not in CHOICES:
        raise RobocalError(f"{ENV}={choice!r} is not one of {', '.join(CHOICES)}; unset it or pick one")
    return choice


def _load(module: str) -> ModuleType | None:
    if module not in _loaded:
        try:
            _loaded[module] = importlib.import_module(module)
        except ImportError:  # numba absent (or unusable with this numpy): the numpy path runs
            _loaded[module] = None
    return _loaded[module]


def compiled(module: str) -> ModuleType | None:
    """The compiled twin ``module`` (e.g. ``"robocal.kinematics.fk_numba"``) when the numba kernels
    are in use, else None (run the numpy path). RobocalError when numba is forced but missing."""
    choice = _choice()
    if choice == "numpy":
        return None
    kernel = _load(module)
    if kernel is None and choice == "numba":
        raise RobocalError(f"{ENV}=numba but numba cannot be imported; install the optional extra "
                           "(pip install 'robocal[fast]') or set it to auto or numpy")
    return kernel


def active() -> str:
    """``"numba"`` or ``"numpy"``: the kernels that run now (the FK kernel decides for all)."""
    return "numba" if compiled("robocal.kinematics.fk_numba") is not None else "numpy"


@contextmanager
def use_kernels(choice: str) -> Iterator[None]:
    """Run the enclosed code with ``choice`` (``auto``, ``numpy``, ``numba``) whatever the
    environment says; not thread-safe (meant for tests and benchmarks)."""
    global _forced
    if choice not in CHOICES:
        raise RobocalError(f"kernels must be one of {', '.join(CHOICES)}, got {choice!r}")
    previous, _forced = _forced, choice
    try:
        yield
    finally:
        _forced = previous
