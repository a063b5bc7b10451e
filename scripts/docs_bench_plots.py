"""MkDocs hook: the Benchmarks page's plots, drawn from ``benchmarks/results.json`` when the site
is built (inline SVG, so they work offline and cannot drift from the tables below them).

``<!-- generated: benchmark-plots -->`` becomes: the accuracy on real data before and after
calibration (``bench_calibrate``'s ``real`` table and the held-out means of ``bench_priors``), and
the speed of the kinematics against each peer that the same run measured (``bench_fk``,
``bench_ik``). A peer that a run did not measure is not drawn.
"""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH_RESULTS = ROOT / "benchmarks" / "results.json"
PLOTS_MARK = "<!-- generated: benchmark-plots -->"
BEFORE_AFTER = re.compile(r"([0-9.]+)\s*->\s*([0-9.]+)")
COLOURS = {"before": "#d9822b", "after": "#2e8b57"}


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs' signature
    if PLOTS_MARK in markdown:
        markdown = markdown.replace(PLOTS_MARK, plots_markdown(BENCH_RESULTS))
    return markdown


def _tables(runs: dict, name: str) -> list[dict]:
    return runs.get(name, {}).get("tables", [])


def accuracy_rows(runs: dict) -> list[tuple[str, float, float]]:
    """(label, before mm, after mm) for every real-data and held-out comparison the results hold."""
    rows = []
    for table in _tables(runs, "bench_calibrate"):
        if table.get("key") == "real":
            cols = table["columns"]
            i_data, i_method = cols.index("data"), cols.index("method")
            i_before, i_after = cols.index("nominal + frame RMS"), cols.index("RMS")
            rows += [(f"{r[i_data]}, {r[i_method]} (RMS)", float(r[i_before]), float(r[i_after]))
                     for r in table["rows"]]
    for table in _tables(runs, "bench_priors"):
        cols = table["columns"]
        if table.get("key") in ("ur5", "seven_axis") and "held-out mean before -> after (mm)" in cols:
            i_case, i_ba = cols.index("case"), cols.index("held-out mean before -> after (mm)")
            for r in table["rows"]:
                found = BEFORE_AFTER.search(str(r[i_ba]))
                if found:
                    rows.append((f"{table['key'].replace('_', '-')}: {r[i_case]} (mean)",
                                 float(found.group(1)), float(found.group(2))))
    return rows


def speed_rows(runs: dict) -> list[tuple[str, list[tuple[str, float]]]]:
    """(benchmark, [(implementation, time per item in its unit)]) of bench_fk and bench_ik's first
    table: robocal's kernels and the peers measured in the same run."""
    out = []
    for name, unit in (("bench_fk", "wall ns/item"), ("bench_ik", "wall us/item")):
        tables = [t for t in _tables(runs, name) if unit in t["columns"]]
        if tables:
            i = tables[0]["columns"].index(unit)
            bars = [(str(r[0]), float(r[i])) for r in tables[0]["rows"]]
            for extra in _tables(runs, name):  # peers timed apart (pinocchio: one call per pose)
                if extra.get("key") == "pinocchio" and unit in extra["columns"]:
                    j = extra["columns"].index(unit)
                    bars += [(str(r[0]), float(r[j])) for r in extra["rows"]
                             if not str(r[0]).startswith("robocal")]
            out.append((f"{name.removeprefix('bench_').upper()} ({unit.removeprefix('wall ')})", bars))
    return out


def _svg(fig) -> str:
    buffer = io.StringIO()
    fig.savefig(buffer, format="svg", bbox_inches="tight", metadata={"Date": None})
    text = buffer.getvalue()
    return text[text.index("<svg"):].replace("\n", " ")  # one line: Markdown keeps a raw HTML block


def accuracy_figure(rows: list[tuple[str, float, float]]) -> str:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 0.45 * len(rows) + 1.0))
    y = range(len(rows))
    ax.barh([k + 0.2 for k in y], [r[1] for r in rows], height=0.4, color=COLOURS["before"],
            label="nominal model")
    ax.barh([k - 0.2 for k in y], [r[2] for r in rows], height=0.4, color=COLOURS["after"],
            label="calibrated (held out)")
    ax.set_yticks(list(y), [r[0] for r in rows])
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("position error (mm, log scale)")
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(axis="x", alpha=0.3)
    svg = _svg(fig)
    plt.close(fig)
    return svg


def speed_figure(groups: list[tuple[str, list[tuple[str, float]]]]) -> str:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(groups), figsize=(7.5, 2.6), squeeze=False)
    for ax, (title, bars) in zip(axes[0], groups, strict=True):
        ax.barh(range(len(bars)), [b[1] for b in bars],
                color=[COLOURS["after"] if b[0].startswith(("robocal", "solve_all")) else "#777777"
                       for b in bars])
        ax.set_yticks(range(len(bars)), [b[0] for b in bars], fontsize=8)
        ax.invert_yaxis()
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("time per pose (shorter is faster)", fontsize=8)
    fig.tight_layout()
    svg = _svg(fig)
    plt.close(fig)
    return svg


def plots_markdown(path: Path) -> str:
    """The plots as Markdown with inline SVG; a note where the results or matplotlib are missing."""
    if not path.exists():
        return "*No benchmark results: run `make bench` to draw the plots.*\n"
    try:
        import matplotlib

        matplotlib.use("Agg")
        matplotlib.rcParams.update({"svg.fonttype": "none", "svg.hashsalt": "robocal"})
    except ImportError:
        return "*The plots need matplotlib (`pip install '.[docs]'`).*\n"
    runs = json.loads(path.read_text(encoding="utf-8"))["benchmarks"]
    out = []
    accuracy, speed = accuracy_rows(runs), speed_rows(runs)
    if accuracy:
        out += ["### Accuracy on real and simulated robots, before and after", "",
                '<div class="bench-plot">' + accuracy_figure(accuracy) + "</div>", "",
                "Before: the nominal model with its best-fitting tracker frame; after: the calibrated "
                "model on poses it did not see. The numbers are in the tables of `bench_calibrate` "
                "and `bench_priors` below.", ""]
    if speed:
        out += ["### Speed of the kinematics against the peers measured in the same run", "",
                '<div class="bench-plot">' + speed_figure(speed) + "</div>", "",
                "Green: robocal's kernels; grey: the peers each run measured (`bench_fk`, `bench_ik`).", ""]
    return "\n".join(out) if out else "*The results hold no table the plots draw.*\n"
