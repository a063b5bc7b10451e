"""One line on the terminal when the compiled kernels are built (their first use on a machine).

numba compiles a kernel the first time it runs and caches it on disk (``__pycache__``, or
``NUMBA_CACHE_DIR``); a fresh clone's first ``robocal filter`` spends ~20 s on it. numba broadcasts
a ``numba:compile`` event only after its cache had no code for the kernel's signature on this
machine (a cache miss: the disk cache is looked up first, a hit loads silently), so the first such
event for one of robocal's cached kernels is the moment to say so, once per process. The line goes
to standard error and only when that is a terminal: a log or a test capturing the output is not
changed by the state of a cache. Installed by :func:`robocal.kinematics.kernels.compiled` when it
imports a compiled twin.
"""

from __future__ import annotations

import sys

from numba.core import event

COMPILE_SECONDS = 20  # what compiling every kernel takes on a laptop (measured 14-24 s on 2 cores)
MESSAGE = (f"robocal: compiling the fast kernels once: ~{COMPILE_SECONDS} s (later runs load them "
           "from the cache)")


def is_cached_robocal_kernel(dispatcher) -> bool:
    """Whether ``dispatcher`` is one of robocal's kernels compiled with ``cache=True`` (a kernel
    without a disk cache compiles on every run: telling it 'once' would be wrong)."""
    from numba.core.caching import Cache

    module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
    return module.startswith("robocal.") and isinstance(getattr(dispatcher, "_cache", None), Cache)


class CompileNotice(event.Listener):
    """Writes :data:`MESSAGE` to ``stream`` (default: standard error when it is a terminal) at the
    first cache miss of a robocal kernel; then nothing."""

    def __init__(self, stream=None) -> None:
        self.stream = stream
        self.told = False

    def on_start(self, ev) -> None:
        if self.told or not is_cached_robocal_kernel((ev.data or {}).get("dispatcher")):
            return
        self.told = True
        stream = self.stream if self.stream is not None else sys.stderr
        if self.stream is not None or stream.isatty():
            print(MESSAGE, file=stream, flush=True)

    def on_end(self, ev) -> None:
        """Nothing to say when a compile ends."""


_installed: list[CompileNotice] = []


def install() -> CompileNotice:
    """Listen for compiles (once per process; later calls return the same listener)."""
    if not _installed:
        _installed.append(CompileNotice())
        event.register("numba:compile", _installed[0])
    return _installed[0]
