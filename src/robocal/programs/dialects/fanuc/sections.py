"""The sections of a FANUC TP .ls file (``/PROG``, ``/ATTR``, ``/MN``, ``/POS``, ``/END``): each
header starts a line; the same word elsewhere (a remark ``! see /POS``, a position's comment) is
no section."""

from __future__ import annotations

import re

from robocal.core.bom import BOM_PATTERN

_HEADS: dict[str, re.Pattern] = {}


def section(text: str, name: str, start: int = 0) -> int:
    """Offset of the header ``/name`` at the start of a line of ``text`` (a lone CR ends a line
    too; a UTF-8 byte-order mark may precede the first), at or after ``start``; -1 if none."""
    if name not in _HEADS:
        _HEADS[name] = re.compile(rf"(?:(?<=[\r\n])|\A{BOM_PATTERN})[ \t]*(/{name})\b")
    m = _HEADS[name].search(text, start)
    return m.start(1) if m else -1


def main_section(text: str) -> tuple[int, int] | None:
    """``(start, stop)`` offsets of the /MN section of ``text`` (its instructions): from its header
    to the /POS header after it, else to the end of the text; None without /MN. The one span the
    reader's motions, the register and frame writes and the marker all look in."""
    start = section(text, "MN")
    if start < 0:
        return None
    stop = section(text, "POS", start)
    return start, stop if stop >= 0 else len(text)
