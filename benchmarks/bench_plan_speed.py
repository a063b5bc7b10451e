"""Speed of planning for the robot's unmodelled error (``robocal poses --unmodelled-mm``,
``rc.plan_poses(unmodelled_mm=)``): the whole command, and its search against the previous one.

1. The command line, in a fresh interpreter each time: ``robocal poses --robot abb_irb120 -n 20
   --unmodelled-mm 0.4`` (5,000 generated candidates, one SMR: 3 rows per pose) and the same plan
   for the noise alone (what the rest of the command costs), alternating, best of
   ``CLI_ROUNDS``; wall-clock and CPU time of the child process. With ``BENCH_PLAN_SPEED_BASELINE``
   set to another source tree (e.g. an older checkout's ``src``), its command is timed in the same
   rounds (before / after in the same minutes).
2. The search alone, in-process, on the problems the planner hands it: the candidate forms
   updated by rank r per design change (``robocal.campaign.unmodelled.Scans``) against the
   previous search (kept here as the reference: a ``(p, p)`` inverse and ``(C r, p) x (p, p)``
   products per member tried), alternating, best of ``SEARCH_ROUNDS``; both must choose the same
   design with the same value (1e-9). Cases: the 5,000 generated IRB 120 candidates above, and
   the real IRB 120 calibration poses (500 candidates, as bench_campaign plans them) when the
   data sets are present.

The machine's load average is printed with every table: the machine may be shared.
"""

from __future__ import annotations

import copy
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import results

import robocal as rc
from robocal.campaign import planner, unmodelled
from robocal.campaign.exchange import IMPROVEMENT_RTOL, MAX_SWEEPS, RIDGE
from robocal.campaign.unmodelled import _cross, _values, mean_square, search

CLI_ROUNDS = 3
SEARCH_ROUNDS = 2
UNMODELLED_MM = 0.4
IRB120_REAL_UNMODELLED_MM = 0.55  # bench_campaign's figure for the real IRB 120
SRC = Path(__file__).resolve().parents[1] / "src"
DATASETS = Path(__file__).resolve().parents[2] / "shared" / "datasets"


def load() -> str:
    return "/".join(f"{x:.2f}" for x in os.getloadavg())


# ----------------------------------------------------------------------------- the command line
def cli_seconds(src: Path, args: list[str]) -> tuple[float, float]:
    """(wall s, CPU s) of one ``robocal`` run with ``src`` first on the path (bytecode cached)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(src), os.environ.get("PYTHONPATH")]))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import sys; from robocal.cli import main; sys.exit(main())",
                    *args], env=env, check=True, capture_output=True)
    wall = time.perf_counter() - wall
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def command_line() -> None:
    trees = {"this version": SRC}
    if os.environ.get("BENCH_PLAN_SPEED_BASELINE"):
        trees["previous version"] = Path(os.environ["BENCH_PLAN_SPEED_BASELINE"])
    with tempfile.TemporaryDirectory() as tmp:
        base = ["--quiet", "poses", "--robot", "abb_irb120", "-n", "20", "-o", str(Path(tmp) / "poses.csv")]
        runs = {(tree, label): args for tree in trees
                for label, args in (("noise only", base), (f"--unmodelled-mm {UNMODELLED_MM}",
                                                            [*base, "--unmodelled-mm", str(UNMODELLED_MM)]))}
        for src in trees.values():  # cache the bytecode before timing
            cli_seconds(src, ["--help"])
        start = load()
        best = {key: (np.inf, np.inf) for key in runs}
        for _ in range(CLI_ROUNDS):
            for key, args in runs.items():
                wall, cpu = cli_seconds(trees[key[0]], args)
                best[key] = (min(best[key][0], wall), min(best[key][1], cpu))
    rows = [[tree, label, f"{wall:.1f}", f"{cpu:.1f}"] for (tree, label), (wall, cpu) in best.items()]
    results.table(f"robocal poses --robot abb_irb120 -n 20 (5,000 generated candidates), best of "
                  f"{CLI_ROUNDS} alternating runs (s); load average {start} -> {load()} on "
                  f"{os.cpu_count()} cores",
                  ["source", "plan", "wall", "CPU"], rows, key="cli")
    unmodelled = f"--unmodelled-mm {UNMODELLED_MM}"
    results.figure("cli_unmodelled_s", f"{best['this version', unmodelled][0]:.1f}")
    results.figure("cli_noise_only_s", f"{best['this version', 'noise only'][0]:.1f}")
    results.figure("cli_load", start.split("/")[0])
    if "previous version" in trees:
        results.figure("cli_previous_unmodelled_s", f"{best['previous version', unmodelled][0]:.1f}")


# ----------------------------------------------------------------------------- the previous search
def previous_scan(G, A, um, M, X, candidates) -> np.ndarray:
    """The previous scan: ``V`` after adding each of ``candidates`` by a Woodbury update with a
    ``(p, p)`` inverse and ``(C r, p) x (p, p)`` products per scan."""
    B = np.linalg.inv(M)
    B = 0.5 * (B + B.T)
    P, C = um.variance, um.A_cross
    T0 = B @ X
    Gc = G[candidates]
    K_, r, p = Gc.shape
    rows = Gc.reshape(-1, p)

    def per_candidate(Y: np.ndarray) -> np.ndarray:
        return Y.reshape(K_, r, -1)

    GB = per_candidate(rows @ B)
    GBA = per_candidate(GB.reshape(-1, p) @ A)
    S_inv = np.linalg.inv(np.einsum("krp,ksp->krs", GB, Gc) + np.eye(r))
    GDG = np.einsum("krp,ksp->krs", GBA, GB)
    K = np.einsum("krs,ksa->kra", S_inv, um.N[candidates] - per_candidate(rows @ T0))
    base = np.einsum("ij,ji->", B, A) + np.einsum("ia,ia,a->", T0, A @ T0, P) - 2.0 * np.einsum(
        "ia,ia,a->", T0, C, P) + um.rms_m**2
    KP = K * P
    return (base - np.einsum("krs,ksr->k", S_inv, GDG)
            + 2.0 * np.einsum("kra,kra->k", KP, per_candidate(GBA.reshape(-1, p) @ T0))
            + np.einsum("kra,krs,ksa->k", KP, GDG, K, optimize=True)
            - 2.0 * np.einsum("kra,kra->k", KP, per_candidate(GB.reshape(-1, p) @ C)))


def previous_polish(G, A, prior, um, members, blocked_by, rng):
    members = [int(m) for m in members]
    blocked = np.sum([blocked_by(m) for m in members], axis=0)
    M = np.diag(prior) + RIDGE * np.eye(G.shape[-1]) + np.einsum("cri,crj->ij", G[members], G[members])
    X = _cross(G, um, members)
    current = float(_values(M[None], X[None], A, um)[0])
    for _ in range(MAX_SWEEPS):
        changed = False
        for i in rng.permutation(members):
            i = int(i)
            M_i, X_i = M - G[i].T @ G[i], X - G[i].T @ um.N[i]
            allowed = np.flatnonzero(blocked - blocked_by(i) == 0)
            tried = previous_scan(G, A, um, M_i, X_i, allowed)
            best = int(np.argmin(tried))
            j = int(allowed[best])
            if j == i or not tried[best] < current - IMPROVEMENT_RTOL * current:
                continue
            members[members.index(i)] = j
            blocked += blocked_by(j) - blocked_by(i)
            M, X, current = M_i + G[j].T @ G[j], X_i + G[j].T @ um.N[j], float(tried[best])
            changed = True
        if not changed:
            break
    return np.asarray(sorted(members), int), mean_square(G, A, prior, um, members)


def previous_search(*args):
    """``search`` (the same starts and their order) polishing with :func:`previous_polish`."""
    saved, unmodelled.polish = unmodelled.polish, previous_polish
    try:
        return unmodelled.search(*args)
    finally:
        unmodelled.polish = saved


def search_problem(robot, n: int, **kw) -> tuple:
    """The arguments ``plan_poses`` hands the unmodelled-error search."""
    captured = []

    def spy(*args):
        captured.append(copy.deepcopy(args))  # the random generator before the search draws from it
        return search(*args)

    saved, planner.search = planner.search, spy
    try:
        rc.plan_poses(robot, n, **kw)
    finally:
        planner.search = saved
    return captured[0]


def searches() -> None:
    robot = rc.Robot.from_catalog("abb_irb120")
    cases = {"IRB 120, 5,000 generated, 1 SMR": search_problem(robot, 20, unmodelled_mm=UNMODELLED_MM)}
    if DATASETS.is_dir():
        from robocal.data.datasets import irb120

        cal = irb120(DATASETS)[0]
        cases["IRB 120, its 500 real calibration poses"] = search_problem(robot, 20, candidates=cal,
                                                                  unmodelled_mm=IRB120_REAL_UNMODELLED_MM)
    else:
        print(f"IRB 120 data set not found at {DATASETS}: the real-pose case is skipped")
    start, rows = load(), []
    for name, (G, A, prior, um, init, conflicts, rng, starts) in cases.items():
        best = {"previous": np.inf, "now": np.inf}
        found = {}
        for _ in range(SEARCH_ROUNDS):
            for label, fn in (("previous", previous_search), ("now", search)):
                fresh = copy.deepcopy(rng)  # the planner's generator as the search gets it
                t = time.perf_counter()
                found[label] = fn(G, A, prior, um, init, conflicts, fresh, starts)
                best[label] = min(best[label], time.perf_counter() - t)
        same = np.array_equal(found["previous"][0], found["now"][0])
        assert same and abs(found["now"][1] / found["previous"][1] - 1) < 1e-9, name
        ratio = best["previous"] / best["now"]
        rows.append([name, len(G), G.shape[1], G.shape[2], um.N.shape[2], f"{best['previous']:.2f}",
                     f"{best['now']:.2f}", f"{ratio:.1f}x", "yes" if same else "no"])
        if len(G) == 5000:
            results.figure("search_speedup_5000", f"{ratio:.1f}")
            results.figure("search_5000_s", f"{best['now']:.2f}")
    results.table(f"The unmodelled-error search (the noise-optimal design and {starts} random starts "
                  f"polished), previous against now, best of {SEARCH_ROUNDS} alternating runs (s); "
                  f"load average {start} -> {load()}",
                  ["case", "candidates", "rows per pose", "unknowns", "unmodelled terms", "previous", "now",
                   "faster", "same design"], rows, key="search")


def main() -> None:
    command_line()
    searches()


if __name__ == "__main__":
    main()
