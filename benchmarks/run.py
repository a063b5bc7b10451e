"""Run every ``benchmarks/bench_*.py`` (each exposes ``main()`` that prints its results) and write
what each printed, its recorded tables and figures, the machine and the date to ``benchmarks/results.json``,
from which the documentation's benchmark page is built.

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
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # the benchmarks share benchmarks/timing.py and results.py

import results  # noqa: E402

from robocal.core.io import write_atomic  # noqa: E402
from robocal.core.version import __version__  # noqa: E402

RESULTS = HERE / "results.json"


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


def git_commit() -> str | None:
    """The checkout's commit (with ``+changes`` when the work tree differs from it), None outside git."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=HERE, capture_output=True, text=True, check=True,
                              timeout=30).stdout.strip()
    try:
        commit = git("rev-parse", "--short=12", "HEAD")
        return commit + ("+changes" if git("status", "--porcelain", "--untracked-files=no") else "")
    except (OSError, subprocess.SubprocessError):
        return None


def run_one(path: Path) -> dict:
    """Run one benchmark file's ``main()``, printing as it goes; its JSON entry."""
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    results.TABLES.clear()
    results.FIGURES.clear()
    entry = {"date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M"),
             "machine": machine(), "robocal_version": __version__, "git_commit": git_commit(),
             "description": " ".join((module.__doc__ or "").split("\n\n")[0].split())}
    print(f"== {path.name}", flush=True)
    tee, stdout = _Tee(sys.stdout), sys.stdout
    start = time.perf_counter()
    sys.stdout = tee
    try:
        module.main()
    finally:
        sys.stdout = stdout
    entry["seconds"] = round(time.perf_counter() - start, 1)
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
        entry = run_one(path)
        # read again just before writing: another run may have added its benchmarks meanwhile
        runs = json.loads(args.json.read_text())["benchmarks"] if args.json.exists() else {}
        runs[path.stem] = entry
        write_atomic(args.json, json.dumps({"benchmarks": runs}, indent=1) + "\n")  # after each one
    return 0


if __name__ == "__main__":
    sys.exit(main())
