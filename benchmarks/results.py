"""Tables and single figures a benchmark records for ``benchmarks/results.json`` (and prints), so
that the documentation is generated from a run, never typed by hand.

A table or figure given a ``key`` can be placed in any documentation page: ``<!-- bench:
priors.ur5 -->`` (the table ``ur5`` of bench_priors, with the machine and date it ran on) or
``{{ bench.priors.ur5_rms_mm }}`` (one figure); see ``scripts/docs_hooks.py``."""

from __future__ import annotations

TABLES: list[dict] = []  # the tables recorded since ``benchmarks/run.py`` started the benchmark
FIGURES: dict[str, str] = {}  # the single figures recorded since then, by key


def table(title: str, columns: list[str], rows: list[list], key: str | None = None) -> None:
    """Record (and print) one table: ``columns`` names, ``rows`` of cells (numbers already rounded
    to what they mean, or strings); ``key`` names it for the documentation's pages."""
    TABLES.append({"title": title, "columns": list(columns), "rows": [list(r) for r in rows],
                   **({"key": key} if key else {})})
    widths = [max(len(str(c)) for c in col) for col in zip(columns, *rows, strict=False)]
    print(f"  {title}")
    for row in [columns, *rows]:
        print("    " + "  ".join(str(c).rjust(w) for c, w in zip(row, widths, strict=False)))


def figure(key: str, text: str) -> str:
    """Record one figure, already formatted with what it means (``"0.0350"``, ``"4 of 6"``), under
    ``key`` for the documentation's pages; returns ``text`` for the benchmark's own printout."""
    if key in FIGURES:
        raise ValueError(f"benchmark figure {key!r} recorded twice")
    FIGURES[key] = str(text)
    return str(text)
