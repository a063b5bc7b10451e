"""Memory a calibration will need, checked before it starts; running out as one clean line.

A calibration's memory grows linearly with the poses (its Jacobians and normal equations are
computed in chunks, so nothing grows faster): per pose, at most ``BYTES_PER_POSE`` with the default
error-model search (``nongeometric="auto"``, the superset of every joint-error term and its
cross-validation) and ``GEOMETRIC_BYTES_PER_POSE`` for the geometric model alone, above what the
process already holds (the interpreter, numpy, the data). ``benchmarks/bench_scale.py`` measures
the slopes these bound (peak RSS against poses, 1,000 to 100,000 poses).

:func:`check_memory` refuses a computation that cannot fit in what the machine offers: the memory
the kernel reports available (``MemAvailable`` plus free swap) and the process's address-space
limit (``ulimit -v``) minus what it has already mapped. Without a way to tell (no ``/proc``), it
lets the computation run; a ``MemoryError`` then still ends as the same one line (the CLI).
"""

from __future__ import annotations

import ctypes
import functools
import gc
import resource
from pathlib import Path

from robocal.core.errors import ResourceError

try:  # optional (extra 'threads'): small least-squares problems run best on one BLAS thread
    from threadpoolctl import ThreadpoolController
except ImportError:  # pragma: no cover - without it the BLAS library keeps its own thread count
    ThreadpoolController = None

BYTES_PER_POSE = 24_000  # default error-model search: bounds the measured 9.4 kB (RSS) and the address space
GEOMETRIC_BYTES_PER_POSE = 8_000  # geometric model only (--nongeometric none)
FIXED_BYTES = 300_000_000  # chunked temporaries, BLAS buffers and the result, whatever the poses
# residual rows (10,000 tracker poses) below which a calibration runs its linear algebra on one BLAS
# thread: its products and decompositions are of (k x k) or thin (rows x k) matrices, which gain
# nothing from threads and lose much to them on a busy machine (100 poses, 2 cores at load 10:
# the whole calibration 2.5-4x faster, its damped solve 4-10x; bench_calibrate's speed case)
SMALL_PROBLEM_ROWS = 30_000
# evaluating a model on a measurement file: bounds the measured ~1.2 kB per row of peak RSS (the
# rows' arrays, the model's frames and the residual test's shuffles; bench_scale's evaluate case)
EVALUATION_BYTES_PER_ROW = 3_000
EVALUATION_ADVICE = ("evaluate a subset of the rows (split the file, e.g. by pose ranges) or run on a "
                     "machine with more memory")
ADVICE = ("calibrate fewer poses (a subset, e.g. every second pose), use --nongeometric none (the "
          "geometric model needs about a third of the memory) or run on a machine with more memory")
GENERAL_ADVICE = ("ask for less (fewer poses, candidates, starts or rows) or run on a machine with more "
                  "memory")
COMMAND_ADVICE = {"calibrate": ADVICE, "evaluate": EVALUATION_ADVICE, "check": EVALUATION_ADVICE}


def _meminfo() -> dict[str, int]:
    """``/proc/meminfo`` in bytes (empty where there is none)."""
    try:
        lines = Path("/proc/meminfo").read_text().splitlines()
    except OSError:
        return {}
    out = {}
    for line in lines:
        key, _, rest = line.partition(":")
        parts = rest.split()
        if parts and parts[0].isdigit():
            out[key] = int(parts[0]) * (1024 if parts[1:] == ["kB"] else 1)
    return out


def _mapped_bytes() -> int | None:
    """The process's address space in use (VmSize), bytes; None where it cannot be read."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def available_bytes() -> int | None:
    """Bytes a computation can still allocate: the smaller of the kernel's available memory (with
    free swap) and the address-space limit minus what is mapped; None when neither is known."""
    limits = []
    info = _meminfo()
    if "MemAvailable" in info:
        limits.append(info["MemAvailable"] + info.get("SwapFree", 0))
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    mapped = _mapped_bytes()
    if soft != resource.RLIM_INFINITY and mapped is not None:
        limits.append(max(soft - mapped, 0))
    return min(limits) if limits else None


def calibration_bytes(n_poses: int, searched: bool) -> int:
    """Memory a calibration of ``n_poses`` poses needs beyond what is held already (bytes);
    ``searched``: the default error-model search (else named terms or the geometric model)."""
    return FIXED_BYTES + n_poses * (BYTES_PER_POSE if searched else GEOMETRIC_BYTES_PER_POSE)


def evaluation_bytes(n_rows: int) -> int:
    """Memory an evaluation of a model on ``n_rows`` measurement rows needs beyond what is held
    already (bytes)."""
    return FIXED_BYTES + n_rows * EVALUATION_BYTES_PER_ROW


def check_memory(needed: int, what: str, advice: str = ADVICE) -> None:
    """ResourceError, before anything starts, when ``needed`` bytes cannot be had (see
    :func:`available_bytes`); ``what`` names the computation, ``advice`` what to do instead."""
    have = available_bytes()
    if have is not None and needed > have:
        raise ResourceError(f"{what} needs about {_gb(needed)} of memory, this machine offers "
                            f"{_gb(have)}: {advice}")


def out_of_memory(what: str, command: str = "calibrate") -> str:
    """The one line for a computation that ran out of memory anyway, with the advice of ``command``
    (the calibration's advice was given for a ``poses --candidates 100000000`` too)."""
    return f"{what} ran out of memory: {COMMAND_ADVICE.get(command, GENERAL_ADVICE)}"


def memory_guard(what: str):
    """Decorator: a ``MemoryError`` inside the function becomes a ResourceError saying ``what``
    ran out of memory and what to do (:func:`out_of_memory`); the memory it held is freed."""
    def wrap(fn):
        @functools.wraps(fn)
        def guarded(*args, **kwargs):
            try:
                return fn(*args, **kwargs)
            except MemoryError:
                pass  # leave the handler first: the traceback's frames (and their arrays) go with it
            raise ResourceError(out_of_memory(what))
        return guarded
    return wrap


def _gb(n: int) -> str:
    return f"{n / 1e9:.2f} GB"


@functools.cache
def _controller():
    return None if ThreadpoolController is None else ThreadpoolController()


def few_threads(rows_of):
    """Decorator: the function runs on one BLAS thread when ``rows_of(*args, **kwargs)`` (its
    problem's residual rows) is below :data:`SMALL_PROBLEM_ROWS` and ``threadpoolctl`` is
    installed; unchanged otherwise."""
    def wrap(fn):
        @functools.wraps(fn)
        def limited(*args, **kwargs):
            controller = _controller()
            if controller is None or rows_of(*args, **kwargs) >= SMALL_PROBLEM_ROWS:
                return fn(*args, **kwargs)
            with controller.limit(limits=1, user_api="blas"):
                return fn(*args, **kwargs)
        return limited
    return wrap


def gc_paused(fn):
    """Decorator: Python's cycle collector is off while ``fn`` runs (and back as it was after).
    A function that builds hundreds of thousands of small objects that all stay alive (a
    100,000-target program's parsed numbers, targets and table rows) otherwise pays one full
    collection, a walk over every live object, each time the survivors grow by a quarter: about a
    third of reading a 100,000-target RAPID module. What it frees is freed by reference counting;
    cycles wait for the next collection."""
    @functools.wraps(fn)
    def paused(*args, **kwargs):
        was = gc.isenabled()
        gc.disable()
        try:
            return fn(*args, **kwargs)
        finally:
            if was:
                gc.enable()
    return paused


@functools.cache
def _libc():
    try:
        return ctypes.CDLL("libc.so.6")  # glibc (Linux); elsewhere nothing to trim
    except OSError:
        return None


def heap_trimmed(fn):
    """Decorator: after ``fn`` returns, the memory its freed objects held goes back to the
    operating system (glibc ``malloc_trim``; a no-op elsewhere). Reading a 100,000-target program
    frees some 300 MB of small blocks when it is done that the C library would otherwise keep, and
    the text written next (the target table, tens of MB) would add to them: the peak resident
    memory of filtering it falls from about 1,050 to under 1,000 MB."""
    @functools.wraps(fn)
    def trimmed(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        finally:
            libc = _libc()
            if libc is not None and hasattr(libc, "malloc_trim"):
                libc.malloc_trim(0)
    return trimmed
