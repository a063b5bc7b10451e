"""MkDocs hook: the Benchmarks page's plots, drawn from ``benchmarks/results.json`` when the site
is built (inline SVG, so they work offline and cannot drift from the tables below them).

``<!-- generated: benchmark-plots -->`` becomes: the accuracy on real data before and after
calibration (``bench_calibrate``'s ``real`` table and the held-out means of ``bench_priors``), and
the speed of the kinematics against each peer that the same run measured (``bench_fk``,
``bench_ik``). A peer that a run did not measure is not drawn. The plots are drawn for a phone's
width (labels above the bars, the legend above the axes) and scale with their column.

``<!-- generated: benchmark-runs -->`` becomes a table of every run: its date, commit and load, and
a mark on a run that measured uncommitted changes, recorded no commit, or ran at a load above
:data:`QUIET_LOAD` (`run_marks`; the page's "Ran ..." lines say the same).
"""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH_RESULTS = ROOT / "benchmarks" / "results.json"
PLOTS_MARK = "<!-- generated: benchmark-plots -->"
RUNS_MARK = "<!-- generated: benchmark-runs -->"
QUIET_LOAD = 2.0  # a run at a higher load average (2 cores busy) is marked: not a quiet machine's timings
DIRTY_SUFFIX = "+changes"  # how benchmarks/run.py marked a commit with uncommitted changes before `dirty`
BEFORE_AFTER = re.compile(r"([0-9.]+)\s*->\s*([0-9.]+)")
COLOURS = {"before": "#d9822b", "after": "#2e8b57"}
PEER = "#777777"  # a peer's bar
WIDTH_IN = 4.8  # inches: drawn for a phone's column (390 px) as much as a desktop's, shown at most this wide
FONT = 11  # pt at the drawn size: ~11 px on a 390 px phone (the figure shown ~0.78 of it)


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs' signature
    if PLOTS_MARK in markdown:
        markdown = markdown.replace(PLOTS_MARK, plots_markdown(BENCH_RESULTS))
    if RUNS_MARK in markdown:
        markdown = markdown.replace(RUNS_MARK, runs_markdown(BENCH_RESULTS))
    return markdown


# ----------------------------------------------------------------- how clean each run was
def run_commit(run: dict) -> str | None:
    """The commit a run measured (without an older entry's ``+changes`` suffix); None: not recorded."""
    commit = run.get("git_commit")
    return commit.removesuffix(DIRTY_SUFFIX) if commit else None


def run_dirty(run: dict) -> bool | None:
    """Whether the run measured uncommitted changes (``dirty``; an older entry: its commit's
    ``+changes`` suffix); None when no commit was recorded."""
    if run.get("dirty") is not None:
        return bool(run["dirty"])
    commit = run.get("git_commit")
    return None if not commit else commit.endswith(DIRTY_SUFFIX)


def run_load(run: dict) -> float | None:
    """The load the run ran under: the highest 1-minute load average sampled during it (``load.max``,
    benchmarks/run.py); an older entry, the highest of the 1-, 5- and 15-minute averages at its start."""
    sampled = (run.get("load") or {}).get("max")
    if sampled is not None:
        return float(sampled)
    start = (run.get("machine") or {}).get("load_average") or []
    finite = [float(x) for x in start if x is not None and float(x) == float(x)]
    return max(finite) if finite else None


def run_marks(run: dict) -> list[str]:
    """What makes a run's figures less than a clean machine's: no commit recorded, uncommitted
    changes, a load above :data:`QUIET_LOAD` (empty for a clean run)."""
    marks = []
    dirty, load = run_dirty(run), run_load(run)
    if dirty is None:
        marks.append("no commit recorded")
    elif dirty:
        marks.append("uncommitted changes")
    if load is None:
        marks.append("load not recorded")
    elif load > QUIET_LOAD:
        marks.append(f"load {load:.2f} > {QUIET_LOAD:g}")
    return marks


def runs_sentence(runs: dict, names: tuple[str, ...]) -> str:
    """One sentence saying the commit and load of each of ``names``' runs, and which are marked."""
    parts = []
    for name in names:
        run = runs.get(name)
        if run is None:
            continue
        commit, load, marks = run_commit(run), run_load(run), run_marks(run)
        shown = "?" if load is None else f"{load:.2f}"
        said = f"`{name}` at {commit or 'an unrecorded commit'}, load {shown}"
        parts.append(said + (f" (**marked: {'; '.join(marks)}**)" if marks else ""))
    return ("Runs: " + ", ".join(parts) + ".") if parts else ""


def runs_markdown(path: Path) -> str:
    """A table of every run of ``path``: when, which commit, under which load, and its marks."""
    if not path.exists():
        return "*No benchmark results: run `make bench`.*\n"
    runs = json.loads(path.read_text(encoding="utf-8"))["benchmarks"]
    rows = ["| benchmark | ran (UTC) | commit | load | marked |", "|---|---|---|---|---|"]
    for name in sorted(runs):
        run = runs[name]
        load = run_load(run)
        marks = run_marks(run)
        rows.append(f"| [`{name}`](#{name}) | {run.get('date', '?')} | "
                    f"{run_commit(run) or '&ndash;'}{' + changes' if run_dirty(run) else ''} | "
                    f"{'&ndash;' if load is None else f'{load:.2f}'} | "
                    f"{'**' + '; '.join(marks) + '**' if marks else 'clean'} |")
    clean = sum(not run_marks(runs[n]) for n in runs)
    return "\n".join([f"{clean} of {len(runs)} runs are clean: at a recorded commit without uncommitted "
                      f"changes, the machine's load at most {QUIET_LOAD:g} throughout (the highest 1-minute "
                      "load average sampled during the run; for a run recorded before the sampling, the "
                      "highest average at its start). A marked run's timings are slower and noisier than a "
                      "quiet machine's, and a run on uncommitted changes measured code no commit holds.",
                      "", *rows, ""])


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
    """The figure as one line of inline SVG that scales with its column (no fixed size: a phone
    shows it at its width, a wide screen at most at its drawn size)."""
    buffer = io.StringIO()
    fig.savefig(buffer, format="svg", bbox_inches="tight", metadata={"Date": None})
    text = buffer.getvalue()
    text = text[text.index("<svg"):].replace("\n", " ")  # one line: Markdown keeps a raw HTML block
    size = re.search(r'width="([0-9.]+)pt" height="([0-9.]+)pt"', text)
    if size:
        text = text.replace(size.group(0), f'style="width:100%;max-width:{size.group(1)}pt;height:auto"', 1)
    return text


def _labelled_bars(ax, labels: list[str], series: list[tuple[str, list[float], str | list[str]]]) -> None:
    """Horizontal bars, one group per label (``series``: name, one value per label, a colour or one
    per bar), the label written above its group (not beside it: the bars keep the figure's width on
    a phone) and each bar's value at its end."""
    k = len(series)
    height = 0.7 / k
    for j, (name, values, colour) in enumerate(series):
        y = [i + (j + 0.5) * height for i in range(len(labels))]
        ax.barh(y, values, height=height * 0.92, color=colour, label=name or None)
        for yy, v in zip(y, values, strict=True):
            ax.text(v, yy, f" {v:,.0f}" if v >= 1000 else f" {v:.3g}", va="center", ha="left",
                    fontsize=FONT - 1, color="#333333")
    for i, label in enumerate(labels):
        ax.text(0.0, i - 0.02, label, transform=ax.get_yaxis_transform(), va="bottom", ha="left",
                fontsize=FONT)
    ax.set_yticks([])
    ax.set_ylim(len(labels) - 0.2, -0.35)
    ax.margins(x=0.18)  # room for the values at the bars' ends
    ax.grid(axis="x", alpha=0.3)
    for side in ("top", "right", "left"):
        ax.spines[side].set_visible(False)


def accuracy_figure(rows: list[tuple[str, float, float]]) -> str:
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    fig, ax = plt.subplots(figsize=(WIDTH_IN, 0.62 * len(rows) + 0.9))
    _labelled_bars(ax, [r[0] for r in rows],
                   [("nominal model", [r[1] for r in rows], COLOURS["before"]),
                    ("calibrated (held out)", [r[2] for r in rows], COLOURS["after"])])
    ax.set_xscale("log")
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))  # 0.1, not mathtext 10^-1
    ax.set_xlabel("position error (mm, log scale)", fontsize=FONT)
    ax.tick_params(labelsize=FONT - 1)
    # above the bars, never over them
    ax.legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncols=2, frameon=False, fontsize=FONT,
              borderaxespad=0.1)
    svg = _svg(fig)
    plt.close(fig)
    return svg


def speed_figure(groups: list[tuple[str, list[tuple[str, float]]]]) -> str:
    import matplotlib.pyplot as plt

    heights = [0.5 * len(bars) + 0.7 for _, bars in groups]
    fig, axes = plt.subplots(len(groups), 1, figsize=(WIDTH_IN, sum(heights) + 0.3), squeeze=False,
                             gridspec_kw={"height_ratios": heights})
    for ax, (title, bars) in zip(axes[:, 0], groups, strict=True):
        colours = [COLOURS["after"] if b[0].startswith(("robocal", "solve_all")) else PEER for b in bars]
        _labelled_bars(ax, [b[0] for b in bars], [("", [b[1] for b in bars], colours)])
        ax.set_title(title, fontsize=FONT, loc="left")
        ax.set_xlabel("time per pose (shorter is faster)", fontsize=FONT)
        ax.tick_params(labelsize=FONT - 1)
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
                "and `bench_priors` below. " + runs_sentence(runs, ("bench_calibrate", "bench_priors")), ""]
    if speed:
        out += ["### Speed of the kinematics against the peers measured in the same run", "",
                '<div class="bench-plot">' + speed_figure(speed) + "</div>", "",
                "Green: robocal's kernels; grey: the peers each run measured (`bench_fk`, `bench_ik`). "
                + runs_sentence(runs, ("bench_fk", "bench_ik")), ""]
    return "\n".join(out) if out else "*The results hold no table the plots draw.*\n"
