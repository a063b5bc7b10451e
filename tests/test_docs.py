"""The documentation's generated pages and the README's links: the command-line reference covers
every command from the parser, the benchmarks page is built from results JSON (or says there is
none), and every README link points at a file in the repository. (`make docs` builds the site
with warnings as errors; `make test` runs it.)"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import docs_hooks  # noqa: E402

from robocal.cli import COMMANDS  # noqa: E402


def test_cli_reference_has_every_command_and_option():
    text = docs_hooks.cli_markdown()
    for name in COMMANDS:
        assert f"\n## robocal {name}\n" in text, name
    start = text.index("## robocal calibrate")
    section = text[start:text.index("## robocal", start + 5)]
    for option in ("--robot ROBOT", "--validate VAL.csv", "--nongeometric TERMS", "--hold-out N", "--force"):
        assert f"`{option}`" in section, option


def test_benchmarks_page_without_results_says_so(tmp_path):
    text = docs_hooks.benchmarks_markdown(tmp_path / "missing.json")
    assert "No benchmark results" in text and "make bench" in text


def test_benchmarks_page_is_built_from_the_json(tmp_path):
    run = {"date": "2026-01-02 03:04", "seconds": 12.3, "robocal_version": "9.9",
           "description": "FK speed | pipes", "output": "line one\nline two\n",
           "machine": {"cpu": "Test CPU", "cores": 2, "load_average": [1.0, 0.5, 0.2], "platform": "Linux",
                       "python": "3.11", "numpy": "2.0"},
           "tables": [{"title": "speed", "columns": ["", "wall (s)"], "rows": [["robocal", "0.010"]]}]}
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"benchmarks": {"bench_fk": run}}))
    text = docs_hooks.benchmarks_markdown(path)
    assert "## bench_fk" in text and "2026-01-02 03:04" in text and "Test CPU" in text
    assert "| robocal | 0.010 |" in text and "    line two" in text
    assert "FK speed &#124; pipes" in text  # a pipe in a cell does not split the table


def test_committed_benchmark_results_render():
    path = ROOT / "benchmarks" / "results.json"
    if path.exists():
        assert "## bench_" in docs_hooks.benchmarks_markdown(path)


def test_readme_is_short_and_its_links_exist():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 150
    links = re.findall(r"\]\(([^)#]+)\)", text)
    assert links
    for link in links:
        if "://" not in link:
            assert (ROOT / link).exists(), link


def _results(tmp_path):
    run = {"date": "2026-01-02 03:04", "seconds": 12.3, "robocal_version": "9.9", "output": "",
           "machine": {"cpu": "Test CPU", "cores": 2, "load_average": [1.0, 0.5, 0.2], "platform": "Linux",
                       "python": "3.11", "numpy": "2.0"},
           "tables": [{"title": "UR5", "key": "ur5", "columns": ["case", "RMS"],
                       "rows": [["default", "0.0350"]]}],
           "figures": {"ur5_rms": "0.0350"}}
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"benchmarks": {"bench_priors": run}}))
    return path


def test_bench_references_are_replaced_by_recorded_tables_and_figures(tmp_path):
    page = "RMS {{ bench.priors.ur5_rms }} mm.\n\n<!-- bench: priors.ur5 -->\n\n<!-- bench: priors -->\n"
    text = docs_hooks.bench_references(page, _results(tmp_path))
    assert text.startswith("RMS 0.0350 mm.")
    assert "| default | 0.0350 |" in text and "**UR5**" in text
    assert text.count("Measured by `benchmarks/bench_priors.py`: Ran 2026-01-02 03:04") == 2
    assert "Test CPU" in text and "bench:" not in text and "{{" not in text


@pytest.mark.parametrize("page", ["{{ bench.priors.ur5_mean }}", "<!-- bench: priors.seven_axis -->",
                                  "<!-- bench: ik -->", "{{ bench.filter.speed_slowest_s }}",
                                  "{{ bench.priors }}", "<!-- bench: priors.ur5.rms -->"])
def test_bench_reference_to_a_missing_key_fails_the_build(tmp_path, page):
    path = _results(tmp_path)
    with pytest.raises(docs_hooks.BenchReferenceError, match="no (figure|table|benchmark)|malformed"):
        docs_hooks.bench_references(page, path)
    with pytest.raises(docs_hooks.BenchReferenceError, match="does not exist"):
        docs_hooks.bench_references(page, tmp_path / "missing.json")


def test_every_bench_reference_in_the_docs_is_in_the_committed_results():
    """What `make docs` (mkdocs --strict) would refuse, checked without building the site."""
    path = ROOT / "benchmarks" / "results.json"
    for page in (ROOT / "docs").rglob("*.md"):
        text = page.read_text(encoding="utf-8")
        if docs_hooks.BENCH_ANY.search(text):
            docs_hooks.bench_references(text, path)
