"""The UTF-8 byte-order mark, defined once: a file saved by a Windows editor starts with it.

Robot programs are read as latin-1 (one character a byte: :mod:`robocal.programs.source`), where the
mark shows as three characters; JSON, YAML and project files are read as UTF-8, where it is one.
Every reader that skips the mark, and every writer that keeps it first, uses this module.
"""

from __future__ import annotations

BOM_BYTES = b"\xef\xbb\xbf"
BOMS = (BOM_BYTES.decode("latin-1"), BOM_BYTES.decode("utf-8"))  # as latin-1 text shows it, and decoded
BOM_PATTERN = "(?:" + "|".join(BOMS) + ")?"  # a regular expression's optional mark at a file's start


def bom_length(text: str) -> int:
    """How many characters of ``text``'s start are a byte-order mark (0 when it has none): where a
    line put first goes, and where a language's signature is looked for."""
    return next((len(b) for b in BOMS if text.startswith(b)), 0)


def without_bom(text: str) -> str:
    """``text`` without a byte-order mark at its start. Offsets in the file keep the mark."""
    return text[bom_length(text):]


def decode_utf8(data: bytes, errors: str = "strict") -> str:
    """``data`` decoded as UTF-8, a byte-order mark at its start dropped (``errors`` as for
    :meth:`bytes.decode`)."""
    return without_bom(data.decode("utf-8", errors))
