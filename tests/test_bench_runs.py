"""Every benchmark run records its commit, whether the work tree had uncommitted changes and the
machine's load while it ran (benchmarks/run.py); the Benchmarks page marks a run on uncommitted
changes, without a commit or at a load above 2 (scripts/docs_bench_plots.py), and its plots scale
with a phone's column."""

from __future__ import annotations

import importlib.util
import json
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import docs_bench_plots as plots  # noqa: E402
import docs_hooks  # noqa: E402


@pytest.fixture(scope="module")
def run_py():
    spec = importlib.util.spec_from_file_location("bench_run", ROOT / "benchmarks" / "run.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_run_records_commit_dirty_flag_and_load(run_py, tmp_path, monkeypatch):
    monkeypatch.setattr(run_py, "LOAD_EVERY_S", 0.02)
    bench = tmp_path / "bench_tiny.py"
    bench.write_text('"""A tiny benchmark."""\nimport time\n\n\ndef main():\n    time.sleep(0.2)\n'
                     '    print("done")\n', encoding="utf-8")
    entry = run_py.run_one(bench, tmp_path / "results.json")
    assert entry["output"] == "done\n" and entry["description"] == "A tiny benchmark."
    if entry["git_commit"] is not None:  # a git checkout (not an exported tarball)
        assert len(entry["git_commit"]) == 12 and isinstance(entry["dirty"], bool)
        assert entry["dirty"] == bool(entry.get("dirty_files"))
    load = entry["load"]
    assert load["samples"] >= 3 and load["every_s"] == 0.02
    assert min(load["start"], load["end"]) <= load["mean"] <= load["max"]
    assert len(entry["machine"]["load_average"]) == 3


def test_the_results_file_does_not_make_a_run_dirty(run_py, tmp_path):
    state = run_py.git_state()
    if state["git_commit"] is None:
        pytest.skip("not a git checkout")
    results = run_py.RESULTS
    if not results.exists():
        pytest.skip("no benchmarks/results.json in this checkout")
    text = results.read_text(encoding="utf-8")
    try:
        results.write_text(text + " ", encoding="utf-8")  # what run.py does between two benchmarks
        assert run_py.git_state(results)["dirty"] == state["dirty"]
        assert run_py.git_state(tmp_path / "other.json")["dirty"] is True  # it counts for another target
    finally:
        results.write_text(text, encoding="utf-8")


def run(**fields) -> dict:
    base = {"date": "2026-12-06 12:00", "seconds": 10.0, "robocal_version": "0.1.0",
            "git_commit": "abc123def456", "dirty": False, "load": {"max": 1.2},
            "output": "", "description": "d",
            "machine": {"cpu": "cpu", "cores": 2, "load_average": [1.0, 1.0, 1.0], "platform": "linux",
                        "python": "3.11", "numpy": "2"}}
    return {**base, **fields}


@pytest.mark.parametrize("fields, marks", [
    ({}, []),
    ({"dirty": True}, ["uncommitted changes"]),
    ({"dirty": None, "git_commit": "abc123def456+changes"}, ["uncommitted changes"]),  # an older entry
    ({"dirty": None, "git_commit": None}, ["no commit recorded"]),
    ({"load": {"max": 4.78}}, ["load 4.78 > 2"]),
    ({"load": None, "machine": {"load_average": [0.5, 2.4, 1.0]}}, ["load 2.40 > 2"]),  # older: start only
])
def test_run_marks(fields, marks):
    assert plots.run_marks(run(**fields)) == marks


def test_the_page_says_each_runs_commit_and_load_and_marks(tmp_path):
    path = tmp_path / "results.json"
    runs = {"bench_a": run(), "bench_b": run(dirty=True, load={"max": 3.0})}
    path.write_text(json.dumps({"benchmarks": runs}))
    table = plots.runs_markdown(path)
    assert "1 of 2 runs are clean" in table
    assert "| [`bench_a`](#bench_a) | 2026-12-06 12:00 | abc123def456 | 1.20 | clean |" in table
    assert "**uncommitted changes; load 3.00 > 2**" in table
    ran = docs_hooks._ran(run(dirty=True, load={"max": 3.0}))
    assert "commit abc123def456, with uncommitted changes" in ran and "load 3.00" in ran
    assert "**Marked: uncommitted changes; load 3.00 > 2.**" in ran
    assert "Marked" not in docs_hooks._ran(run())


def test_quotes_are_not_entities():
    """An entity inside a code span is shown as written: the page showed &quot;auto&quot;."""
    assert docs_hooks._cell('``nongeometric="auto"``') == '``nongeometric="auto"``'
    assert docs_hooks._cell("a | b <c>") == "a &#124; b &lt;c&gt;"


def test_plots_scale_with_their_column():
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    svg = plots.accuracy_figure([("IRB 120, lsq (RMS)", 0.97, 0.6), ("UR5 (mean)", 1.2, 0.03)])
    root = svg[:svg.index(">")]
    assert 'style="width:100%;max-width:' in root and 'width="' not in root.replace("max-width", "")
    assert "nominal model" in svg and "IRB 120, lsq (RMS)" in svg
    start = time.perf_counter()
    speed = plots.speed_figure([("FK (ns/item)", [("robocal Robot.fk (numba)", 62.9), ("peer", 1019.0)]),
                                ("IK (us/item)", [("solve_all (numba)", 1.5), ("peer", 12.8)])])
    assert "1,019" in speed and time.perf_counter() - start < 30
