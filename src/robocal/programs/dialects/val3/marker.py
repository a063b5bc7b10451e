"""The provenance marker of Staubli VAL3: an XML comment ``<!-- ... -->`` on the line after the
XML declaration of each file written (a file without a declaration carries none)
(:mod:`robocal.trust.output_marker`)."""

from __future__ import annotations

import re

from robocal.trust.output_marker import insert_after

_ANCHOR = re.compile(r"^(?:\xef\xbb\xbf)?<\?xml[^>]*\?>[ \t]*(\r\n|\r|\n)")


def mark(text: str, body: str, note: str) -> str:
    """``text`` with the comment ``<!-- note -->`` after its XML declaration (none: unchanged)."""
    return insert_after(text, _ANCHOR, f"<!-- {note} -->") if _ANCHOR.search(text) else text
