"""MkDocs hook: a list that renders as a paragraph fails the build.

Python-Markdown ends a list at a table, at a block it cannot nest or at a missing blank line; the
items after it then render as one paragraph with literal "- " or "1. " in it (how-to/track.md's
section 4 and result-json.md's items after ``conditions`` did). Every rendered ``<p>`` that begins
(or has a line that begins) with a list marker is reported as a warning, which ``mkdocs build
--strict`` turns into a failure.
"""

from __future__ import annotations

import logging
import re

log = logging.getLogger("mkdocs.plugins.docs_lists")

PARAGRAPH = re.compile(r"<p>(.*?)</p>", re.S)
# a list marker at the start of the paragraph or of one of its lines: "- x", "* x", "1. x"
MARKER = re.compile(r"(?:^|\n)\s*(?:[-*]|\d+\.) (?=\S)")


def broken_lists(html: str) -> list[str]:
    """The start of every paragraph of ``html`` that holds a list marker at the start of a line."""
    return [text.strip()[:60] for text in PARAGRAPH.findall(html) if MARKER.search(text)]


def on_page_content(html: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs' signature
    for start in broken_lists(html):
        log.warning(f"{page.file.src_path}: a list renders as a paragraph (a blank line missing before "
                    f"it, or it follows a table or a block it cannot nest): {start!r}")
    return html
