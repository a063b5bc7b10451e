"""Run every ``benchmarks/bench_*.py`` (each exposes ``main()`` that prints its results) and write
what each printed, its recorded tables and figures, the machine and the date to ``benchmarks/results.json``,
from which the documentation's benchmark page is built.

Every run records what its figures depend on: the commit (``git_commit``), whether the work tree
had uncommitted changes (``dirty``, with up to :data:`DIRTY_FILES_KEPT` of the changed files; the
results file itself, which this script rewrites, does not count), and the machine's load: the
1-minute load average sampled every :data:`LOAD_EVERY_S` s while the benchmark runs (``load``:
``start``, ``end``, ``max``, ``mean``). The Benchmarks page marks a run on uncommitted changes or at
a load above 2 (``scripts/docs_bench_plots.py``).

Usage: ``python benchmarks/run.py [NAME ...] [--json PATH]`` -- names filter the files (``fk`` runs
bench_fk.py); the JSON keeps the other benchmarks' earlier entries (each carries its own date).
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import io
import json
import os
import platform
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # the benchmarks share benchmarks/timing.py and results.py

import results  # noqa: E402

from robocal.core.io import write_atomic  # noqa: E402
from robocal.core.version import __version__  # noqa: E402

RESULTS = HERE / "results.json"
LOAD_EVERY_S = 5.0  # seconds between two samples of the load average during a run
DIRTY_FILES_KEPT = 10  # changed files named in a dirty run's entry at most


class _Tee(io.TextIOBase):
    """stdout that also keeps what was written."""

    def __init__(self, stream) -> None:
        self.stream, self.kept = stream, io.StringIO()

    def write(self, text: str) -> int:
        self.kept.write(text)
        return self.stream.write(text)

    def flush(self) -> None:
        self.stream.flush()


def machine() -> dict:
    """What the timings depend on: CPU, cores, load, platform, Python and numpy versions."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {"cpu": cpu, "cores": os.cpu_count(), "load_average": [round(x, 2) for x in load],
            "platform": platform.platform(), "python": platform.python_version(), "numpy": np.__version__}


def git_state(results: Path = RESULTS) -> dict:
    """``git_commit`` (12 digits), ``dirty`` (tracked files differ from it; ``results``, which this
    script rewrites between benchmarks, left out) and ``dirty_files``; None for both outside git."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=HERE, capture_output=True, text=True, check=True,
                              timeout=30).stdout.rstrip()
    try:
        commit = git("rev-parse", "--short=12", "HEAD")
        top = Path(git("rev-parse", "--show-toplevel")).resolve()
        target = results.resolve()
        skip = [f":(top,exclude){target.relative_to(top).as_posix()}"] if target.is_relative_to(top) else []
        status = git("status", "--porcelain", "--untracked-files=no", "--", ":(top)", *skip)
        changed = [line[3:] for line in status.splitlines()]
    except (OSError, subprocess.SubprocessError):
        return {"git_commit": None, "dirty": None}
    return {"git_commit": commit, "dirty": bool(changed),
            **({"dirty_files": changed[:DIRTY_FILES_KEPT]} if changed else {})}


class LoadSampler:
    """The 1-minute load average sampled every :data:`LOAD_EVERY_S` s in a thread while a benchmark
    runs (``with LoadSampler() as load: ...``; then ``load.summary()``)."""

    def __init__(self) -> None:
        self.samples: list[float] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    @staticmethod
    def now() -> float | None:
        return round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None

    def _run(self) -> None:
        while not self._stop.wait(LOAD_EVERY_S):
            if (value := self.now()) is not None:
                self.samples.append(value)

    def __enter__(self) -> LoadSampler:
        if (value := self.now()) is not None:
            self.samples.append(value)
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()
        if (value := self.now()) is not None:
            self.samples.append(value)

    def summary(self) -> dict:
        """``start``, ``end``, ``max``, ``mean`` of the samples (None each without a load average)."""
        s = self.samples
        return {"start": s[0] if s else None, "end": s[-1] if s else None,
                "max": max(s) if s else None, "mean": round(sum(s) / len(s), 2) if s else None,
                "samples": len(s), "every_s": LOAD_EVERY_S}


def run_one(path: Path, results_path: Path = RESULTS) -> dict:
    """Run one benchmark file's ``main()``, printing as it goes; its JSON entry."""
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    results.TABLES.clear()
    results.FIGURES.clear()
    entry = {"date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M"),
             "machine": machine(), "robocal_version": __version__, **git_state(results_path),
             "description": " ".join((module.__doc__ or "").split("\n\n")[0].split())}
    print(f"== {path.name}", flush=True)
    tee, stdout = _Tee(sys.stdout), sys.stdout
    start = time.perf_counter()
    sys.stdout = tee
    try:
        with LoadSampler() as load:
            module.main()
    finally:
        sys.stdout = stdout
    entry["seconds"] = round(time.perf_counter() - start, 1)
    entry["load"] = load.summary()
    print(f"== {path.name} done in {entry['seconds']:.1f} s\n", flush=True)
    return {**entry, "tables": list(results.TABLES), "figures": dict(results.FIGURES),
            "output": tee.kept.getvalue()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="benchmarks to run (fk runs bench_fk.py); default all")
    parser.add_argument("--json", type=Path, default=RESULTS, help="results file (default %(default)s)")
    args = parser.parse_args(argv)
    files = sorted(HERE.glob("bench_*.py"))
    if args.names:
        files = [f for f in files if f.stem.removeprefix("bench_") in args.names]
    for path in files:
        entry = run_one(path, args.json)
        # read again just before writing: another run may have added its benchmarks meanwhile
        runs = json.loads(args.json.read_text())["benchmarks"] if args.json.exists() else {}
        runs[path.stem] = entry
        write_atomic(args.json, json.dumps({"benchmarks": runs}, indent=1) + "\n")  # after each one
    return 0


if __name__ == "__main__":
    sys.exit(main())

