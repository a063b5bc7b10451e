"""Tables a benchmark records for ``benchmarks/results.json`` (and prints), so that the
documentation's benchmark page is generated from a run, never typed by hand."""

from __future__ import annotations

TABLES: list[dict] = []  # the tables recorded since ``benchmarks/run.py`` started the benchmark


def table(title: str, columns: list[str], rows: list[list]) -> None:
    """Record (and print) one table: ``columns`` names, ``rows`` of cells (numbers already rounded
    to what they mean, or strings)."""
    TABLES.append({"title": title, "columns": list(columns), "rows": [list(r) for r in rows]})
    widths = [max(len(str(c)) for c in col) for col in zip(columns, *rows, strict=False)]
    print(f"  {title}")
    for row in [columns, *rows]:
        print("    " + "  ".join(str(c).rjust(w) for c, w in zip(row, widths, strict=False)))
