"""The provenance marker of FANUC TP (.ls): a remark ``!...`` as the last line of ``/MN``,
numbered after the last line, with ``LINE_COUNT`` raised by one; a remark line holds
`TP_REMARK_WIDTH` characters, so the fingerprint is cut to fit (10 hex digits with a
five-character version). The position register file (``--position-registers``, a CSV whose
``#`` lines are comments: :mod:`robocal.programs.dialects.fanuc.registers`) gets ``# ...`` as its
first line (:mod:`robocal.trust.output_marker`)."""

from __future__ import annotations

import re

from robocal.core.bom import bom_length
from robocal.core.errors import DataError
from robocal.programs.dialects.fanuc.campaign import TP_REMARK_WIDTH
from robocal.programs.dialects.fanuc.registers import is_register_file
from robocal.programs.dialects.fanuc.sections import main_section
from robocal.trust.output_marker import newline, shortened

LINE_DIGITS = 9  # a TP line number or LINE_COUNT longer than this is no controller's (a mangled file)
_LINE = re.compile(rf"^[ \t]*(\d{{1,{LINE_DIGITS}}}):", re.M)
_COUNT = re.compile(rf"^(LINE_COUNT\s*=\s*)(\d{{1,{LINE_DIGITS}}})(?!\d)", re.M)


def mark(text: str, body: str, note: str) -> str:
    """``text`` with the remark ``!body`` (cut to fit) as the last line of /MN."""
    span = main_section(text)
    if span is None and is_register_file(text):
        k = bom_length(text)
        return f"{text[:k]}# {note}{newline(text)}{text[k:]}"
    if span is None:
        raise DataError("a FANUC .ls program without /MN cannot carry a provenance marker")
    start, stop = span
    numbers = [int(n) for n in _LINE.findall(text, start, stop)]
    nl = newline(text)
    body = shortened(body, TP_REMARK_WIDTH)
    remark = f"{max(numbers, default=0) + 1:>4}:  !{body} ;{nl}"
    if not text[:stop].endswith(("\n", "\r")):  # its own line, also after a last line without end
        remark = nl + remark
    out = text[:stop] + remark + text[stop:]
    return _COUNT.sub(lambda m: f"{m.group(1)}{int(m.group(2)) + 1}", out, count=1)
