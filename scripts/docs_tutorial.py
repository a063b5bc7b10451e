"""MkDocs hook: under each runnable block of the tutorial and of every how-to page, the output it
printed when the test suite ran it (``tests/test_tutorial.py`` records it in ``PAGE.output.json``
next to the page and checks the page against it), so the expected output on a page is never typed
by hand.

The k-th ``<!-- output -->`` marker of a page becomes the k-th recorded output; a page whose
markers and recorded outputs differ in number fails the build.
"""

from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
TUTORIAL = "tutorial/first-campaign.md"
HOW_TO = "how-to"
OUTPUT_MARK = "<!-- output -->"
RUNNABLE = ("bash", "python")  # fenced blocks of these languages run; ``text``, ``yaml``... are shown only
# the step a reader takes once in every new shell (said where a reader starts: the index, the tutorial)
ACTIVATE = "source .venv/bin/activate"


class TutorialOutputError(ValueError):
    """A page's output markers and its recorded outputs do not match."""


def runnable_pages() -> list[str]:
    """The pages whose blocks the tests run, relative to docs/: the tutorial, then every how-to."""
    return [TUTORIAL] + sorted(f"{HOW_TO}/{p.name}" for p in (DOCS / HOW_TO).glob("*.md"))


def outputs_path(page: str) -> Path:
    """Where the outputs of ``page``'s blocks are recorded: ``docs/how-to/track.output.json``."""
    return (DOCS / page).with_suffix(".output.json")


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs' signature
    if page is None or page.file.src_path not in runnable_pages():
        return markdown
    path = outputs_path(page.file.src_path)
    if OUTPUT_MARK not in markdown and not path.exists():
        return markdown
    if not path.exists():
        raise TutorialOutputError(f"{page.file.src_path} has output markers and no {path.name}: run "
                                  "ROBOCAL_RECORD_TUTORIAL=1 pytest tests/test_tutorial.py")
    return with_outputs(markdown, json.loads(path.read_text(encoding="utf-8"))["outputs"],
                        page.file.src_path)


def with_outputs(markdown: str, outputs: list[str], page: str = TUTORIAL) -> str:
    """``markdown`` with its output markers replaced by ``outputs``, in order."""
    parts = markdown.split(OUTPUT_MARK)
    if len(parts) - 1 != len(outputs):
        raise TutorialOutputError(f"{page} has {len(parts) - 1} output markers and "
                                  f"{outputs_path(page).name} {len(outputs)} recorded outputs: run "
                                  "ROBOCAL_RECORD_TUTORIAL=1 pytest tests/test_tutorial.py")
    out = [parts[0]]
    for text, rest in zip(outputs, parts[1:], strict=True):
        # indented as the fence inside the admonition (4 spaces): the output's own indentation kept
        body = "\n".join("    " + line for line in text.rstrip().splitlines()) or "    (nothing)"
        out += ['???+ success "Output"\n\n    ```text\n', body, "\n    ```\n", rest]
    return "".join(out)
