"""MkDocs hooks: the pages that are generated from the code and from benchmark results, so that they
cannot drift from what they describe.

A page holds a marker comment that the hook replaces when the site is built:

- ``<!-- generated: cli -->``: every ``robocal`` command, from the argparse parser itself;
- ``<!-- generated: program-formats -->``: the robot languages of ``robocal filter --format`` and
  ``robocal poses --program``, from their registry (``robocal.programs.registry``);
- ``<!-- generated: benchmarks -->``: the tables and output of ``benchmarks/results.json``, which
  ``benchmarks/run.py`` (``make bench``) writes;
- ``<!-- bench: NAME.KEY -->``: the table recorded under ``KEY`` by ``benchmarks/bench_NAME.py``,
  with the machine and date it ran on; ``<!-- bench: NAME -->``: that machine and date alone;
- ``{{ bench.NAME.KEY }}``: the single figure recorded under ``KEY`` by ``bench_NAME.py``.

A reference to a benchmark, table or figure that ``results.json`` does not hold fails the build:
no measured figure in the documentation is typed by hand.
"""

from __future__ import annotations

import argparse
import html
import json
import os
import re
from pathlib import Path

# the run's marks, defined once (scripts/ is on the path while MkDocs loads a hook, and in the tests)
from docs_bench_plots import run_commit, run_dirty, run_load, run_marks

ROOT = Path(__file__).resolve().parents[1]
BENCH_RESULTS = ROOT / "benchmarks" / "results.json"
CLI_MARK = "<!-- generated: cli -->"
FORMATS_MARK = "<!-- generated: program-formats -->"
BENCH_MARK = "<!-- generated: benchmarks -->"
BENCH_REF = re.compile(r"<!--\s*bench:\s*([a-z0-9_]+)(?:\.([A-Za-z0-9_]+))?\s*-->")
BENCH_FIGURE = re.compile(r"\{\{\s*bench\.([a-z0-9_]+)\.([A-Za-z0-9_]+)\s*\}\}")
BENCH_ANY = re.compile(r"\{\{\s*bench\b|<!--\s*bench:")  # well formed or not


class BenchReferenceError(ValueError):
    """A page refers to a benchmark, table or figure that the results file does not hold."""


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs' signature
    if CLI_MARK in markdown:
        markdown = markdown.replace(CLI_MARK, cli_markdown())
    if FORMATS_MARK in markdown:
        from robocal.programs.registry import format_table

        markdown = markdown.replace(FORMATS_MARK, format_table())
    if BENCH_MARK in markdown:
        markdown = markdown.replace(BENCH_MARK, benchmarks_markdown(BENCH_RESULTS))
    if BENCH_ANY.search(markdown):
        where = f" (page {page.file.src_path})" if page is not None else ""
        try:
            markdown = bench_references(markdown, BENCH_RESULTS)
        except BenchReferenceError as exc:
            raise BenchReferenceError(f"{exc}{where}") from None
    return markdown


# ----------------------------------------------------------------- command line
def _cell(text: str) -> str:
    """Text for a Markdown table cell: HTML-escaped, no pipes, no emphasis markers, one line."""
    # quotes stay quotes: an entity inside a code span would be shown as written (&quot;auto&quot;)
    return " ".join(html.escape(text, quote=False).replace("|", "&#124;").replace("*", "&#42;").split())


def _paragraph(text: str) -> str:
    """Text for a Markdown paragraph, one line: escaped as :func:`_cell` outside code spans, and
    not inside them (a code span escapes its text itself: escaping it here too showed
    ``nongeometric=&quot;auto&quot;`` on the page)."""
    parts = re.split(r"(`+[^`]*`+)", " ".join(text.split()))
    return "".join(part if part.startswith("`")
                   else html.escape(part, quote=False).replace("|", "&#124;").replace("*", "&#42;")
                   for part in parts)


def _expanded_help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    if not action.help or action.help == argparse.SUPPRESS:
        return ""
    return parser._get_formatter()._expand_help(action)  # noqa: SLF001 - argparse's own %-expansion


def _argument_rows(parser: argparse.ArgumentParser) -> list[str]:
    rows = []
    for action in parser._actions:  # noqa: SLF001 - the parser's arguments, in order
        if isinstance(action, argparse._HelpAction):  # noqa: SLF001
            continue
        if action.option_strings:
            metavar = ""
            if action.nargs != 0:
                metavar = " " + (action.metavar if isinstance(action.metavar, str) else action.dest.upper())
            name = ", ".join(f"`{s}{metavar}`" for s in action.option_strings)
        else:
            name = f"`{action.metavar or action.dest}`"
        default = ""
        if action.option_strings and action.nargs != 0 and action.default not in (None, False, "", [],
                                                                                 argparse.SUPPRESS):
            default = f"`{action.default}`"
        choices = f" (one of: {', '.join(map(str, action.choices))})" if action.choices else ""
        rows.append(f"| {name} | {_cell(_expanded_help(parser, action) + choices)} | {default} |")
    return rows


def cli_markdown() -> str:
    """One section per ``robocal`` subcommand: what it does, usage, arguments, the example."""
    os.environ["COLUMNS"] = "100"  # argparse wraps the usage lines at the terminal width
    from robocal.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))  # noqa: SLF001
    helps = {c.dest: c.help for c in sub._choices_actions}  # noqa: SLF001
    out = ["## robocal", "", "```text", parser.format_usage().strip(), "```", "",
           "| argument | meaning | default |", "|---|---|---|", *_argument_rows(parser), ""]
    for name, cmd in sub.choices.items():
        out += [f"## robocal {name}", "", helps.get(name) or "", ""]
        if cmd.description:
            out += [cmd.description, ""]
        out += ["```text", cmd.format_usage().strip(), "```", "",
                "| argument | meaning | default |", "|---|---|---|", *_argument_rows(cmd), ""]
        if cmd.epilog:
            out += ["```text", cmd.epilog.strip(), "```", ""]
    return "\n".join(out)


# ----------------------------------------------------------------- benchmarks
def _table(table: dict) -> list[str]:
    columns = table["columns"]
    out = [f"**{_cell(table['title'])}**", "", "| " + " | ".join(_cell(c) for c in columns) + " |",
           "|" + "---|" * len(columns)]
    out += ["| " + " | ".join(_cell(str(v)) for v in row) + " |" for row in table["rows"]]
    return out + [""]


def _ran(run: dict) -> str:
    machine = run["machine"]
    commit = (f" (commit {run_commit(run)}{', with uncommitted changes' if run_dirty(run) else ''})"
              if run_commit(run) else " (commit not recorded)")
    load = run_load(run)
    marks = run_marks(run)
    return (f"Ran {run['date']} (UTC) in {run['seconds']:.0f} s with robocal {run['robocal_version']}"
            f"{commit} "
            f"on {_cell(machine['cpu'])}, {machine['cores']} cores, load "
            f"{'not recorded' if load is None else f'{load:.2f}'}, {_cell(machine['platform'])}, "
            f"Python {machine['python']}, numpy {machine['numpy']}."
            + (f" **Marked: {'; '.join(marks)}.**" if marks else ""))


def _run(runs: dict, name: str, path: Path) -> dict:
    run = runs.get(f"bench_{name}")
    if run is None:
        raise BenchReferenceError(f"no benchmark 'bench_{name}' in {path.name}: run "
                                  f"`python benchmarks/run.py {name}`")
    return run


def bench_references(markdown: str, path: Path) -> str:
    """``markdown`` with its benchmark references (``<!-- bench: NAME.KEY -->``, ``<!-- bench: NAME
    -->``, ``{{ bench.NAME.KEY }}``) replaced by what ``path`` (run.py's JSON) recorded;
    :class:`BenchReferenceError` naming the first one it does not hold."""
    if not path.exists():
        raise BenchReferenceError(f"{path.name} does not exist: run `make bench` (or "
                                  "`python benchmarks/run.py NAME ...`) before building the documentation")
    runs = json.loads(path.read_text(encoding="utf-8"))["benchmarks"]

    def ref(match: re.Match) -> str:
        name, key = match.groups()
        run = _run(runs, name, path)
        source = f"Measured by `benchmarks/bench_{name}.py`: {_ran(run)}"
        if key is None:
            return source
        table = next((t for t in run.get("tables", []) if t.get("key") == key), None)
        if table is None:
            raise BenchReferenceError(f"no table '{key}' in bench_{name}'s results: record it with "
                                      f"results.table(..., key={key!r}) and run the benchmark")
        return "\n".join([*_table(table), source, ""])

    def figure(match: re.Match) -> str:
        name, key = match.groups()
        figures = _run(runs, name, path).get("figures", {})
        if key not in figures:
            raise BenchReferenceError(f"no figure '{key}' in bench_{name}'s results: record it with "
                                      f"results.figure({key!r}, ...) and run the benchmark")
        return _cell(figures[key])

    out = BENCH_FIGURE.sub(figure, BENCH_REF.sub(ref, markdown))
    bad = BENCH_ANY.search(out)
    if bad:
        line = out[bad.start():].splitlines()[0]
        raise BenchReferenceError(f"malformed benchmark reference {line!r}: write <!-- bench: NAME.KEY -->, "
                                  "<!-- bench: NAME --> or {{ bench.NAME.KEY }}")
    return out


def benchmarks_markdown(path: Path) -> str:
    """Every benchmark of ``path`` (``benchmarks/run.py``'s JSON): where and when it ran, its
    tables and its printed output; a note saying so when there is no such file."""
    if not path.exists():
        return ("!!! note \"No benchmark results\"\n    `benchmarks/results.json` does not exist: "
                "run `make bench` (or `python benchmarks/run.py NAME ...`) to produce it.\n")
    runs = json.loads(path.read_text(encoding="utf-8"))["benchmarks"]
    out = []
    for name in sorted(runs):
        run = runs[name]
        out += [f"## {name}", "", _paragraph(run.get("description", "")), "", _ran(run), ""]
        for table in run.get("tables", []):
            out += _table(table)
        if run.get("figures"):
            out += ["**Figures the documentation quotes**", "", "| key | figure |", "|---|---|",
                    *(f"| `{k}` | {_cell(v)} |" for k, v in run["figures"].items()), ""]
        fold = "???" if run.get("tables") else "???+"  # open when the output is all there is
        out += [f"{fold} abstract \"Output of the run\"", "", "    ```text",
                *("    " + line for line in run["output"].rstrip().splitlines()), "    ```", ""]
    return "\n".join(out)
