"""The provenance marker of ABB RAPID: ``! ...`` on the line after the first ``MODULE`` line
(the file's first line without one) (:mod:`robocal.trust.output_marker`)."""

from __future__ import annotations

import re

from robocal.core.bom import BOM_PATTERN
from robocal.trust.output_marker import insert_after

_ANCHOR = re.compile(rf"^{BOM_PATTERN}[ \t]*MODULE\b[^\r\n]*(\r\n|\r|\n)", re.M | re.I)


def mark(text: str, body: str, note: str) -> str:
    """``text`` with the comment ``! note`` after its MODULE line."""
    return insert_after(text, _ANCHOR, f"! {note}")
