"""Best-of-n timing, the kernels to time and the py-opw-kinematics peer, shared by the benchmarks."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from results import table

from robocal import Robot
from robocal.ik.opw_ik import opw_form
from robocal.kinematics.kernels import compiled, use_kernels


def best_time(fn, repeat: int = 3, clock=time.perf_counter) -> tuple[float, object]:
    """``(shortest time in s, last result)`` of ``repeat`` calls of ``fn``."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t = clock()
        out = fn()
        best = min(best, clock() - t)
    return best, out


def interleaved(fns: dict, repeat: int) -> dict[str, tuple[float, float]]:
    """``{name: (best wall-clock s, best CPU s)}`` of ``repeat`` rounds calling every ``fns`` entry
    once per round, so that a busy (shared) machine slows them alike. CPU time counts all threads."""
    best = {name: (float("inf"), float("inf")) for name in fns}
    for _ in range(repeat):
        for name, fn in fns.items():
            wall, cpu = time.perf_counter(), time.process_time()
            fn()
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            best[name] = (min(best[name][0], wall), min(best[name][1], cpu))
    return best


def first_call(setup: str, call: str) -> tuple[float, float] | None:
    """Seconds of the first ``call`` in a fresh interpreter after ``setup`` (numba: import, then
    compile), with an empty numba cache and then with the cache that run left; None without numba."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return None
    code = f"{setup}\nimport time\nt = time.perf_counter()\n{call}\nprint(time.perf_counter() - t)"
    src = str(Path(__file__).resolve().parents[1] / "src")
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "ROBOCAL_KERNELS": "numba",
               "PYTHONPATH": os.pathsep.join(filter(None, [src, os.environ.get("PYTHONPATH")]))}
        runs = [subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                               check=True) for _ in range(2)]
    return float(runs[0].stdout.split()[-1]), float(runs[1].stdout.split()[-1])


def print_times(best: dict[str, tuple[float, float]], rows: dict[str, str], n: int, per: str,
                peer: str | None, title: str) -> None:
    """The table ``title`` (recorded for results.json, and printed), one row per ``rows`` entry
    (key in ``best`` -> label): wall clock, time per item in ``per`` (``"ns"`` or ``"us"``), CPU
    time and, except for the peer's own row, the ratios to ``peer``."""
    scale = {"ns": 1e9, "us": 1e6}[per]
    columns = ["", "wall (s)", f"wall {per}/item", "CPU (s)"]
    if peer is not None:
        columns += [f"faster than {peer}, wall", "by CPU time"]
    lines = []
    for key, label in rows.items():
        wall, cpu = best[key]
        line = [label.strip(), f"{wall:.3f}", f"{wall / n * scale:.2f}", f"{cpu:.3f}"]
        if peer is not None:
            pw, pc = best[peer]
            line += ["", ""] if key == peer else [f"{pw / wall:.1f}x", f"{pc / cpu:.1f}x"]
        lines.append(line)
    table(title, columns, lines)


def kernel_choices(module: str) -> list[str]:
    """The kernels to time: ``numpy``, and ``numba`` when the compiled twin ``module`` (e.g.
    ``"robocal.kinematics.fk_numba"``) can be imported."""
    with use_kernels("auto"):
        return ["numpy"] + (["numba"] if compiled(module) is not None else [])


def py_opw_robot(robot: Robot):
    """py-opw-kinematics' ``Robot`` for the OPW form of ``robot`` (radians), or None when the peer
    is not installed."""
    try:
        import py_opw_kinematics as po
    except ImportError:
        return None
    p = opw_form(robot)
    model = po.KinematicModel(a1=p.a1, a2=p.a2, b=p.b, c1=p.c1, c2=p.c2, c3=p.c3, c4=p.c4,
                              offsets=tuple(p.offsets), flip_axes=tuple(s < 0 for s in p.signs))
    return po.Robot(model, degrees=False)
