"""A robot program's text with the byte spans of the numbers that filtering may rewrite.

The file is read as bytes and decoded as latin-1, which maps every byte to one character: string
offsets are byte offsets, any 8-bit or UTF-8 file round-trips byte for byte, and only ASCII numbers
are ever replaced (comments, whitespace, CRLF line endings and encoding stay as they were). Line
ends are read as the controllers read them: LF, CRLF and a lone CR (CR-only files, or mixed) each
end a line; :attr:`ProgramText.text` has every lone CR as LF (same offsets) and
:meth:`ProgramText.replaced` writes the original line ends back.
UTF-16 files are refused with a message. A :class:`Number` keeps its span, text and decimals;
:func:`format_number` writes a corrected value with the file's decimals when they resolve the
correction, more otherwise.
"""

from __future__ import annotations

import bisect
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError

_LONE_CR = re.compile(r"\r(?!\n)")
# \d+(?:\.\d*)? and not \d+\.?\d*: the same numbers, but a run of digits splits one way only (inside a
# longer pattern that then fails, the other form backtracks in quadratic time over the run)
NUMBER_RE = re.compile(r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?")


@dataclass(frozen=True, slots=True)
class Number:
    """A number in the program text: ``start:end`` byte span, its ``text`` and value."""

    start: int
    end: int
    text: str

    @property
    def value(self) -> float:
        return float(self.text)

    @property
    def decimals(self) -> int:
        """Digits after the decimal point as written (0 for an integer or exponent form)."""
        mantissa = self.text.lower().partition("e")[0]
        return len(mantissa) - mantissa.index(".") - 1 if "." in mantissa else 0


TEXT_SHARE = 0.9  # share of text bytes (printable, tab, CR, LF) a text file's first 4 kB has at least
MAX_DIGITS = 1000  # a run of this many digits is no number a controller writes (the file is refused)
_HUGE_DIGITS = re.compile(rf"\d{{{MAX_DIGITS},}}")
UTF16_ZEROS = 0.4  # share of NULs at odd (or even) bytes from which a file is UTF-16 (ASCII code in it)


def _utf16(head: bytes) -> bool:
    """Whether ``head`` (a file's first bytes) is UTF-16 text: its ASCII characters leave NULs in
    every other byte (random binary data has few NULs, and not in one parity)."""
    half = max(len(head) // 2, 1)
    return max(head[1::2].count(0), head[0::2].count(0)) >= UTF16_ZEROS * half


def _binary(head: bytes) -> bool:
    """Whether ``head`` is no text: control bytes (not tab, CR, LF, form feed, ESC) in more than a
    tenth of it (latin-1 decoded, as the dialects read it)."""
    controls = sum(b < 32 and b not in (9, 10, 12, 13, 26, 27) for b in head)
    return controls > (1.0 - TEXT_SHARE) * len(head)


class ProgramText:
    """The text of one program file (latin-1 decoded bytes) and its line starts."""

    def __init__(self, path: str | Path, data: bytes | None = None):
        self.path = Path(path)
        if data is None:
            try:
                data = self.path.read_bytes()
            except OSError as exc:
                raise DataError(f"cannot read program {self.path}: {exc.strerror}") from None
        head = data[:4096]
        if head[:2] in (b"\xff\xfe", b"\xfe\xff") or _utf16(head):
            raise DataError(f"{self.path}: the file looks UTF-16 encoded; save it as UTF-8 or ASCII "
                            "(the controllers' own export format) and run again")
        if b"\x00" in head or _binary(head):
            raise DataError(f"{self.path}: not a program text (binary data: an encrypted, compiled or "
                            "compressed file?); give the module as the controller exports it")
        self.data = data
        self.original = data.decode("latin-1")
        # a lone CR ends a line as LF and CRLF do (old controllers, Mac-era editors): the text the
        # dialects read has it as LF, same length, so offsets and line numbers hold for both
        self.text = _LONE_CR.sub("\n", self.original) if "\r" in self.original else self.original
        self._lines = [0] + [m.end() for m in re.finditer("\n", self.text)]
        first = re.search("\r\n|\n|\r", self.original)
        self._lone_cr_file = first is not None and first.group() == "\r"
        huge = _HUGE_DIGITS.search(self.text)
        if huge:  # no controller writes one; int() of it would fail (Python's 4300-digit limit)
            raise DataError(f"{self.where(huge.start())}: a number of {len(huge.group())} digits: not a "
                            f"program a controller wrote (at most {MAX_DIGITS - 1} digits are read)")
        self._masked: dict[tuple, str] = {}  # (blank, quoted) patterns -> the masked text

    def in_file_line_ends(self, added: str) -> str:
        """Text written for this file in the form of :attr:`text` (lines ended by LF) with the
        file's own line ends: a lone CR in a CR-only file (CRLF and LF are kept as written)."""
        return added.replace("\n", "\r") if self._lone_cr_file else added

    def masked(self, blank: list[re.Pattern], quoted: list[re.Pattern] = ()) -> str:
        """:func:`mask` of the text with these patterns, computed once (the reader and the load
        reader of a language share it)."""
        key = (tuple(blank), tuple(quoted))
        if key not in self._masked:
            self._masked[key] = mask(self.text, blank, quoted)
        return self._masked[key]

    def line_of(self, offset: int) -> int:
        """1-based line number of a byte offset."""
        return bisect.bisect_right(self._lines, offset)

    def numbers_in(self, start: int, end: int) -> list[Number]:
        """Every number inside ``start:end`` in order."""
        return [Number(m.start(), m.end(), m.group()) for m in NUMBER_RE.finditer(self.text, start, end)]

    def where(self, offset: int) -> str:
        """``file:line`` of a byte offset, for messages."""
        return f"{self.path.name}:{self.line_of(offset)}"

    def replaced(self, edits: dict[tuple[int, int], str]) -> bytes:
        """The file's bytes with the spans ``(start, end)`` replaced by new ASCII text."""
        return self.spliced([k[0] for k in edits], [k[1] for k in edits], list(edits.values()))

    def spliced(self, starts: list[int], ends: list[int], texts: list[str]) -> bytes:
        """The file's bytes with each span ``starts[k]:ends[k]`` replaced by ``texts[k]`` (ASCII),
        in any order: built in one bytearray in span order (no list of pieces kept)."""
        out, pos, data = bytearray(), 0, memoryview(self.data)
        for k in np.lexsort((np.asarray(ends, np.int64), np.asarray(starts, np.int64))).tolist():
            if starts[k] < pos:
                raise AssertionError(f"overlapping edits at byte {starts[k]}")
            out += data[pos:starts[k]]
            out += texts[k].encode("latin-1")
            pos = ends[k]
        out += data[pos:]
        return bytes(out)


_NOT_LINE_END = re.compile(r"[^\r\n]")


def mask(text: str, blank: list[re.Pattern], quoted: list[re.Pattern] = ()) -> str:
    """``text`` with every match of ``blank`` (comments) turned to spaces and of ``quoted``
    (strings) to ``"___"``, newlines kept: structure can be searched without being fooled, a
    string still reads as one item, and offsets stay the same. Only the matches are rebuilt (a
    100,000-target program is not copied character by character)."""

    def spaces(m: re.Match) -> str:
        return _NOT_LINE_END.sub(" ", m.group())

    def underscores(m: re.Match) -> str:
        s = m.group()
        return s if len(s) < 2 else s[0] + _NOT_LINE_END.sub("_", s[1:-1]) + s[-1]

    for patterns, fill in ((blank, spaces), (quoted, underscores)):
        if patterns:
            combined = re.compile("|".join(f"(?:{p.pattern})" for p in patterns), re.MULTILINE)
            text = combined.sub(fill, text)
    return text


def format_number(value: float, old: Number, resolution: float, decimals: int = 0) -> str:
    """Text for ``value`` replacing ``old``: unchanged when within ``resolution / 2`` of the old
    value; else with the old number's decimals (at least ``decimals``: the file's precision for
    this kind of number), or as many more as ``resolution`` needs (the quantisation error stays
    below resolution / 2), in the old number's style (a leading '+', '.5' without its zero).
    Never '-0'."""
    if abs(value - old.value) <= resolution / 2:
        return old.text
    needed = max(0, math.ceil(-math.log10(resolution) - 1e-9))  # 10**-needed <= resolution
    decimals = max(old.decimals, needed, decimals)
    text = f"{value:.{decimals}f}"
    if float(text) == 0.0:
        text = text.lstrip("-")
    if old.text.lstrip("+-").startswith(".") and text.lstrip("-").startswith("0."):
        text = text.replace("0.", ".", 1)  # FANUC's '.044' style
    if old.text.startswith("+") and not text.startswith("-"):
        text = "+" + text
    return text
