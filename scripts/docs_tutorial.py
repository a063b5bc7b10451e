"""MkDocs hook: under each runnable block of the tutorial, the output it printed when the test
suite ran it (``tests/test_tutorial.py`` records it in ``docs/tutorial/first-campaign.output.json``
and checks the page against it), so the expected output on the page is never typed by hand.

The k-th ``<!-- output -->`` marker of the page becomes the k-th recorded output; a page whose
markers and recorded outputs differ in number fails the build.
"""

from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = "tutorial/first-campaign.md"
OUTPUTS = ROOT / "docs" / "tutorial" / "first-campaign.output.json"
OUTPUT_MARK = "<!-- output -->"


class TutorialOutputError(ValueError):
    """The tutorial's output markers and its recorded outputs do not match."""


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs' signature
    if page is None or page.file.src_path != PAGE:
        return markdown
    return with_outputs(markdown, json.loads(OUTPUTS.read_text(encoding="utf-8"))["outputs"])


def with_outputs(markdown: str, outputs: list[str]) -> str:
    """``markdown`` with its output markers replaced by ``outputs``, in order."""
    parts = markdown.split(OUTPUT_MARK)
    if len(parts) - 1 != len(outputs):
        raise TutorialOutputError(f"{PAGE} has {len(parts) - 1} output markers and {OUTPUTS.name} "
                                  f"{len(outputs)} recorded outputs: run ROBOCAL_RECORD_TUTORIAL=1 "
                                  "pytest tests/test_tutorial.py")
    out = [parts[0]]
    for text, rest in zip(outputs, parts[1:], strict=True):
        body = "\n".join("        " + line for line in text.rstrip().splitlines()) or "        (nothing)"
        out += ['???+ success "Output"\n\n    ```text\n', body, "\n    ```\n", rest]
    return "".join(out)
