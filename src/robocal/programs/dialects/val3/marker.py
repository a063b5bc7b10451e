"""The provenance marker of Staubli VAL3: an XML comment ``<!-- ... -->`` on the line after the
XML declaration of each file written; in a file without a declaration (which XML allows), as its
first line, before the root element (a declaration must come first; a comment may precede the
root) (:mod:`robocal.trust.output_marker`)."""

from __future__ import annotations

import re

from robocal.core.bom import BOM_PATTERN
from robocal.core.escape import xml_comment_text
from robocal.trust.output_marker import insert_after

_ANCHOR = re.compile(rf"^{BOM_PATTERN}<\?xml[^>]*\?>[ \t]*(\r\n|\r|\n)")


def mark(text: str, body: str, note: str) -> str:
    """``text`` with the comment ``<!-- note -->`` after its XML declaration (none: as the first
    line, after a byte-order mark)."""
    return insert_after(text, _ANCHOR, f"<!-- {xml_comment_text(note)} -->")
