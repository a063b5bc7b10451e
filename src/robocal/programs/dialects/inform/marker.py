"""The provenance marker of Yaskawa INFORM: a comment instruction ``'...`` after the job's
``NOP`` (a comment holds `INFORM_COMMENT_WIDTH` characters: the fingerprint is cut to fit); a
VAR.DAT, which holds no instructions, carries none (:mod:`robocal.trust.output_marker`)."""

from __future__ import annotations

import re

from robocal.trust.output_marker import shortened

INFORM_COMMENT_WIDTH = 32  # characters of an INFORM comment instruction ('...)
_NOP = re.compile(r"^NOP[ \t]*(\r?\n|\r)", re.M)


def mark(text: str, body: str, note: str) -> str:
    """A comment instruction after the job's NOP (the first instruction); a file without one (the
    controller's VAR.DAT, which holds no instructions) is left as it is."""
    m = _NOP.search(text)
    if m is None:
        return text
    return text[:m.end()] + f"'{shortened(body, INFORM_COMMENT_WIDTH)}{m.group(1)}" + text[m.end():]
