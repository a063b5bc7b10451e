"""Scale: time and peak memory (RSS) of ``robocal calibrate`` with the default (the error-model
search) on 1,000 to 100,000 simulated poses, 100,000 poses under a 3 GiB address-space limit
(``ulimit -v``), the geometric model alone, ``robocal evaluate`` of a calibrated model on 1,000 to
100,000-row measurement files, and ``robocal filter`` on 10,000 and 100,000-target RAPID programs;
the growth of memory with the poses (kB per pose, and the exponent of a power law) above what a
process holds with no data, and of evaluate's memory with the rows (kB per row).

Each case runs the command line in a fresh interpreter (its own peak RSS: ``ru_maxrss``), one case
at a time; the machine's load is recorded with the results (the timings depend on it, the memory
does not). ``python benchmarks/bench_scale.py [quick]``: ``quick`` stops at 20,000 poses. With
the environment variable ``BENCH_SCALE_LARGE=1`` (also through ``benchmarks/run.py``) evaluate also
runs on 1,000,000 and 2,700,000 rows (a 500 MB file: the 100,000 simulated poses repeated, each copy
with its own pose ids and line numbers), which takes tens of minutes.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from results import figure, table

ROBOT = "abb_irb2600"
POSES = (1_000, 10_000, 20_000, 100_000)
TARGETS = (10_000, 100_000)
ADDRESS_LIMIT = 3 * 1024**3  # bytes: the 100,000-pose default case runs under this ulimit -v
LIMITED_FROM = 100_000  # the largest pose count, from this many, runs (once) under ADDRESS_LIMIT
GEOMETRIC_AT = 10_000  # poses of the geometric-model case (--nongeometric none)
LARGE_ROWS = (1_000_000, 2_700_000)  # evaluate's large files (BENCH_SCALE_LARGE=1)
SRC = Path(__file__).resolve().parents[1] / "src"
# runs a robocal command line in this interpreter and prints its exit code and peak RSS (kB)
_RUNNER = ("import json, resource, sys\nfrom robocal.cli import main\ncode = main(sys.argv[1:])\n"
           "print(json.dumps({'code': code, 'rss_kb': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}),"
           " file=sys.stderr)")


def _env() -> dict:
    paths = [str(SRC), os.environ.get("PYTHONPATH")]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, paths))}


def run_cli(argv: list[str], address_limit: int | None = None) -> dict:
    """``robocal argv`` in a fresh interpreter: exit code, wall time (s), peak RSS (MB), the last
    line it printed on stderr."""
    def limit():
        if address_limit is not None:
            resource.setrlimit(resource.RLIMIT_AS, (address_limit, address_limit))

    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _RUNNER, "--quiet", *argv], env=_env(), capture_output=True,
                          text=True, preexec_fn=limit)
    wall = time.perf_counter() - t
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    try:
        stats = json.loads(lines[-1])
    except (IndexError, ValueError):  # killed before it could report (e.g. the kernel's OOM killer)
        stats = {"code": proc.returncode, "rss_kb": float("nan")}
    return {"code": stats["code"], "s": wall, "rss_mb": stats["rss_kb"] / 1024,
            "message": lines[-2] if len(lines) > 1 else ""}


def _baseline_mb() -> float:
    """Peak RSS of the interpreter that imported the command line and did nothing (MB)."""
    return run_cli(["robots"])["rss_mb"]


def _load() -> str:
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def calibrate_scale(folder: Path, poses) -> tuple[list, dict]:
    """Rows of the calibration table and the peak RSS (MB) of the default case by pose count."""
    rows, rss = [], {}
    for n in poses:
        data = folder / f"poses{n}.csv"
        sim = run_cli(["simulate", "--robot", ROBOT, "--poses", str(n), "--seed", "1", "-o", str(data),
                       "--truth", str(folder / f"truth{n}.yaml")])
        assert sim["code"] == 0, sim
        # the largest case runs once, under the address-space limit of the goal
        limit = ADDRESS_LIMIT if n == max(poses) and n >= LIMITED_FROM else None
        label = "default (auto)" + (f", ulimit -v {ADDRESS_LIMIT / 1024**3:g} GiB" if limit else "")
        cases = [(label, [], limit)]
        if n == GEOMETRIC_AT:
            cases.append(("--nongeometric none", ["--nongeometric", "none"], None))
        for label, extra, limit in cases:
            load = _load()
            out = run_cli(["calibrate", str(data), "--robot", ROBOT, "-o", str(folder / f"cal{n}.yaml"),
                           *extra], limit)
            if label.startswith("default") and out["code"] == 0:
                rss[n] = out["rss_mb"]
            rows.append([f"{n:,}", label, out["code"], f"{out['s']:.1f}", f"{out['rss_mb']:.0f}", load,
                         out["message"][:120] if out["code"] else ""])
            print(f"    calibrate {n} {label}: exit {out['code']}, {out['s']:.1f} s, {out['rss_mb']:.0f} MB",
                  flush=True)
    return rows, rss


def repeated_csv(source: Path, target: Path, rows: int) -> None:
    """``target``: the measurement rows of ``source`` repeated up to ``rows`` rows, each copy with
    its own pose ids and line numbers (a long campaign's file without simulating it)."""
    lines = source.read_text().splitlines()
    start = next(k for k, line in enumerate(lines) if not line.startswith("#"))
    header = lines[start].split(",")
    pid, src = header.index("pose_id"), header.index("source_row")
    body = [line.split(",") for line in lines[start + 1:]]
    with target.open("w") as f:
        f.write("\n".join(lines[:start + 1]) + "\n")
        for k in range(rows):
            cells = list(body[k % len(body)])
            cells[pid] = str(int(cells[pid]) + (k // len(body)) * len(body))
            cells[src] = str(start + 2 + k)
            f.write(",".join(cells) + "\n")


def evaluate_scale(folder: Path, poses, large: tuple = ()) -> tuple[list, dict]:
    """Rows of the evaluate table and its peak RSS (MB) by rows: the true model of each simulated
    file (calibrate_scale's) judged on it, and the largest file repeated to ``large`` rows."""
    rows, rss = [], {}
    cases = [(n, folder / f"poses{n}.csv") for n in poses]
    biggest = max(poses)
    for n in large:
        repeated_csv(folder / f"poses{biggest}.csv", folder / f"rows{n}.csv", n)
        cases.append((n, folder / f"rows{n}.csv"))
    for n, data in cases:
        model = folder / f"truth{min(n, biggest)}.yaml"
        load = _load()
        out = run_cli(["evaluate", str(model), str(data), "--json", str(folder / "evaluation.json")])
        if out["code"] == 0:
            rss[n] = out["rss_mb"]
        mb = data.stat().st_size / 1e6
        rows.append([f"{n:,}", f"{mb:.0f}", out["code"], f"{out['s']:.1f}", f"{out['rss_mb']:.0f}", load,
                     out["message"][:120] if out["code"] else ""])
        print(f"    evaluate {n} rows ({mb:.0f} MB): exit {out['code']}, {out['s']:.1f} s, "
              f"{out['rss_mb']:.0f} MB", flush=True)
        if n in large:
            data.unlink()
    return rows, rss


def filter_scale(folder: Path, targets) -> list:
    """Rows of the filter table: RAPID programs of ``targets`` targets (bench_filter's generator)."""
    from bench_filter import _joints

    import robocal as rc
    from robocal.data.simulate import perturbed
    from robocal.kinematics.transforms import make_transform
    from robocal.programs.simulate import write_program

    nominal = rc.Robot.from_catalog(ROBOT)
    perturbed(nominal, 0).save(folder / "calibrated.yaml")
    tool = make_transform(np.eye(3), np.array([0.03, 0.0, 0.12]))
    frame = make_transform(np.eye(3), np.array([0.4, -0.1, 0.05]))
    rows = []
    for n in targets:
        sub = folder / f"rapid{n}"
        sub.mkdir()
        q = _joints(nominal, n, np.random.default_rng(1), "rapid")
        paths, _, _ = write_program("rapid", sub, nominal, q, tool, frame)
        load = _load()
        out = run_cli(["filter", *map(str, paths), "--calibrated", str(folder / "calibrated.yaml"),
                       "--nominal", ROBOT, "-o", str(sub / "out"), "--keep-unreached"])
        rows.append([f"{len(q):,}", out["code"], f"{out['s']:.1f}", f"{out['rss_mb']:.0f}", load,
                     out["message"][:120] if out["code"] else ""])
        print(f"    filter {len(q)} targets: exit {out['code']}, {out['s']:.1f} s, {out['rss_mb']:.0f} MB",
              flush=True)
    return rows


def growth(rss: dict, base_mb: float) -> tuple[float, float]:
    """(kB per pose of the least-squares line through peak RSS against poses, exponent of the
    power law through the memory above ``base_mb`` between the smallest and largest case)."""
    n = np.array(sorted(rss), float)
    mb = np.array([rss[k] for k in sorted(rss)])
    slope = np.polyfit(n, mb, 1)[0] * 1024  # kB per pose
    above = np.maximum(mb - base_mb, 1e-9)
    exponent = float(np.log(above[-1] / above[0]) / np.log(n[-1] / n[0])) if n.size > 1 else float("nan")
    return float(slope), exponent


def main(parts: list[str] | None = None) -> None:
    quick = "quick" in (parts or [])
    poses = tuple(p for p in POSES if p <= 20_000) if quick else POSES
    targets = TARGETS[:1] if quick else TARGETS
    base = _baseline_mb()
    large = LARGE_ROWS if os.environ.get("BENCH_SCALE_LARGE") == "1" else ()
    with tempfile.TemporaryDirectory() as tmp:
        rows, rss = calibrate_scale(Path(tmp), poses)
        erows, erss = evaluate_scale(Path(tmp), poses, large)
        frows = filter_scale(Path(tmp), targets)
    slope, exponent = growth(rss, base)
    eslope, _ = growth(erss, base)
    table(f"calibrate {ROBOT} (simulated, one SMR), default error-model search unless noted: wall time and "
          f"peak RSS of the whole command in a fresh interpreter (which holds {base:.0f} MB with no data)",
          ["poses", "case", "exit", "time (s)", "peak RSS (MB)", "load (1/5/15 min)", "message"], rows,
          key="calibrate")
    repeated = "the largest two: the 100,000 poses repeated; " if large else ""
    table(f"evaluate the true model on simulated {ROBOT} measurement files (one SMR, SI columns with 17 "
          f"digits; {repeated}--json written): wall time and peak RSS of the whole command in a fresh "
          "interpreter",
          ["rows", "file (MB)", "exit", "time (s)", "peak RSS (MB)", "load (1/5/15 min)", "message"], erows,
          key="evaluate")
    table(f"filter RAPID programs ({ROBOT}): wall time and peak RSS",
          ["targets", "exit", "time (s)", "peak RSS (MB)", "load (1/5/15 min)", "message"], frows,
          key="filter")
    figure("slope_kb_per_pose", f"{slope:.1f}")
    figure("exponent", f"{exponent:.2f}")
    figure("baseline_mb", f"{base:.0f}")
    for n, mb in rss.items():
        figure(f"rss_{n}_mb", f"{mb:.0f}")
    figure("evaluate_kb_per_row", f"{eslope:.2f}")
    for n, mb in erss.items():
        figure(f"evaluate_rss_{n}_mb", f"{mb:.0f}")
    print(f"  memory: {slope:.1f} kB per pose (least squares over {', '.join(map(str, sorted(rss)))} poses), "
          f"power-law exponent above the {base:.0f} MB baseline {exponent:.2f}; evaluate {eslope:.2f} kB per "
          f"row (least squares over {', '.join(map(str, sorted(erss)))} rows)")


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    main(sys.argv[1:])
