"""Which implementation runs the hot kernels (forward kinematics of one robot, closed-form IK).

numpy is always there; numba compiles faster twins of these kernels when the optional ``fast``
extra is installed (``pip install 'robocal[fast]'``). The choice is automatic and can be forced either
way, for tests and comparisons, by the environment variable ``ROBOCAL_KERNELS`` (``auto``, ``numpy``
or ``numba``) or by :func:`use_kernels`. Both give the same results to rounding (the tests check them
against each other).

``auto`` uses a compiled kernel when numba can be imported, except that a caller giving the size of
its work (``items``) does not make the process import numba for a small one: importing numba and
loading its cached kernels costs about 1.4 s, more than the compiled kernels save on anything below
:data:`LOAD_MIN_ITEMS` items per call (forward kinematics: 0.17 us per pose, 100,000 poses in 17 ms
against numpy's 34 ms). Once numba is imported (by a large call, or by any other kernel), every
call uses it. The first compile of a kernel on a machine (~20 s for all of them) prints one line on
a terminal (:mod:`robocal.kinematics.compile_notice`).
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from types import ModuleType

from robocal.core.errors import RobocalError

ENV = "ROBOCAL_KERNELS"
CHOICES = ("auto", "numpy", "numba")
_forced: str | None = None  # set by use_kernels, wins over the environment
_loaded: dict[str, ModuleType | None] = {}
# items of one call from which ``auto`` imports numba for it (see the module docstring)
LOAD_MIN_ITEMS = 1_000_000


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
        else:  # a compile (a cache miss) says so once on a terminal
            from robocal.kinematics.compile_notice import install

            install()
    return _loaded[module]


def compiled(module: str, items: int | None = None) -> ModuleType | None:
    """The compiled twin ``module`` (e.g. ``"robocal.kinematics.fk_numba"``) when the numba kernels
    are in use, else None (run the numpy path). RobocalError when numba is forced but missing.
    ``items``: the size of the caller's work (e.g. poses); with ``auto``, below
    :data:`LOAD_MIN_ITEMS` it gets the compiled twin only if numba is imported already."""
    choice = _choice()
    if choice == "numpy":
        return None
    if (choice == "auto" and items is not None and items < LOAD_MIN_ITEMS and module not in _loaded
            and "numba" not in sys.modules):
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
