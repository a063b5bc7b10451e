"""The provenance marker of URScript: ``# ...`` as the first line (:mod:`robocal.trust.output_marker`)."""

from __future__ import annotations

from robocal.core.bom import bom_length
from robocal.trust.output_marker import newline


def mark(text: str, body: str, note: str) -> str:
    """``text`` with the comment ``# note`` as its first line (after a byte-order mark)."""
    k = bom_length(text)
    return f"{text[:k]}# {note}{newline(text)}{text[k:]}"
