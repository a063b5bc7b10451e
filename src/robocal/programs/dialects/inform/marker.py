"""The provenance marker of Yaskawa INFORM: a comment instruction ``'...`` after the job's
``NOP`` (a comment holds `INFORM_COMMENT_WIDTH` characters: the fingerprint is cut to fit), or, in a
job without ``NOP`` (an offline generator's), before its first instruction; any line end (CRLF, LF,
a lone CR) is the job's own. A VAR.DAT, which has no comment syntax, carries no line of
robocal's: its corrected copy is marked by its name (``VAR_CAL.DAT``,
:mod:`robocal.trust.output_marker`)."""

from __future__ import annotations

import re

from robocal.trust.output_marker import shortened

INFORM_COMMENT_WIDTH = 32  # characters of an INFORM comment instruction ('...)
_START = r"(?:^|(?<=\r))"  # a line's start after LF (re.M) or after a lone CR
_NOP = re.compile(_START + r"NOP[ \t]*(\r?\n|\r)", re.M)
# //INST and its /// header lines: the first instruction follows them
_INST = re.compile(_START + r"//INST[ \t]*(\r?\n|\r)(?:///[^\r\n]*(?:\r?\n|\r))*", re.M)


def mark(text: str, body: str, note: str) -> str:
    """A comment instruction after the job's NOP (the first instruction), else before its first
    instruction; a file without ``//INST`` (the controller's VAR.DAT, which holds no instructions)
    is left as it is."""
    m = _NOP.search(text) or _INST.search(text)
    if m is None:
        return text
    return text[:m.end()] + f"'{shortened(body, INFORM_COMMENT_WIDTH)}{m.group(1)}" + text[m.end():]
