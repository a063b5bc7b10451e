"""MkDocs hooks: the pages that are generated from the code and from benchmark results, so that they
cannot drift from what they describe.

A page holds a marker comment that the hook replaces when the site is built:

- ``<!-- generated: cli -->``: every ``robocal`` command, from the argparse parser itself;
- ``<!-- generated: benchmarks -->``: the tables and output of ``benchmarks/results.json``, which
  ``benchmarks/run.py`` (``make bench``) writes.
"""

from __future__ import annotations

import argparse
import html
import json
import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH_RESULTS = ROOT / "benchmarks" / "results.json"
CLI_MARK = "<!-- generated: cli -->"
BENCH_MARK = "<!-- generated: benchmarks -->"


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs' signature
    if CLI_MARK in markdown:
        markdown = markdown.replace(CLI_MARK, cli_markdown())
    if BENCH_MARK in markdown:
        markdown = markdown.replace(BENCH_MARK, benchmarks_markdown(BENCH_RESULTS))
    return markdown


# ----------------------------------------------------------------- command line
def _cell(text: str) -> str:
    """Text for a Markdown table cell: HTML-escaped, no pipes, no emphasis markers, one line."""
    return " ".join(html.escape(text).replace("|", "&#124;").replace("*", "&#42;").split())


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
        machine = run["machine"]
        out += [f"## {name}", "", _cell(run.get("description", "")), "",
                f"Ran {run['date']} (UTC) in {run['seconds']:.0f} s with robocal {run['robocal_version']} "
                f"on {_cell(machine['cpu'])}, {machine['cores']} cores, load average "
                f"{machine['load_average']} at the start, {_cell(machine['platform'])}, "
                f"Python {machine['python']}, numpy {machine['numpy']}.", ""]
        for table in run.get("tables", []):
            out += _table(table)
        fold = "???" if run.get("tables") else "???+"  # open when the output is all there is
        out += [f"{fold} abstract \"Output of the run\"", "", "    ```text",
                *("    " + line for line in run["output"].rstrip().splitlines()), "    ```", ""]
    return "\n".join(out)
