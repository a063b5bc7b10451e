"""The numeric body of a measurement CSV, read block by block into arrays.

A large file (millions of rows) is read without a Python object per row or per cell that outlives
its block: the text is split into lines one window at a time (:func:`text_lines`, the same lines
as ``str.splitlines``), and each block of :data:`BLOCK_LINES` lines is converted by numpy's C
parser (``numpy.loadtxt``). A block the C parser does not take as it is (a quoted cell, a value
Python reads but the C parser does not, such as ``1_000``, a wrong number of values, a value
that is not finite or not an integer where one is needed) is read again cell by cell
(:func:`_slow_block`), which accepts exactly what Python's ``float`` accepts and names the line,
the column and the value of the first bad cell. Both paths give the same numbers: the fast one is
only taken where it cannot differ.
"""

from __future__ import annotations

import csv
import itertools
import re
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError

BLOCK_LINES = 4096  # lines converted at once (their Python strings live only for one block)
WINDOW_CHARS = 1 << 22  # characters of text split into lines at a time (4 MB)
# integers, at most MAX_INT in size
INT_COLUMNS = ("smr", "plane", "flush_plane", "pair", "pose_id", "source_row")
MAX_INT = 2**53  # an integer column's values beyond this are not exact in a float
DECIMAL_COMMA = re.compile(r"[-+]?\d+,\d+")  # a number written with a decimal comma (12,5)


def text_lines(text: str, window: int | None = None) -> Iterator[str]:
    """The lines of ``text``, exactly those of ``text.splitlines()``, produced one window of about
    ``window`` characters at a time (default :data:`WINDOW_CHARS`; never a list of every line)."""
    window = window or WINDOW_CHARS
    pos, n = 0, len(text)
    size = window
    while pos < n:
        if pos + size >= n:
            yield from text[pos:].splitlines()
            return
        part = text[pos:pos + size]
        pieces = part.splitlines(keepends=True)
        if len(pieces) < 2:  # one line longer than the window
            size *= 2
            continue
        done = len(part) - len(pieces[-1])  # the last piece may continue (or end in half a CR LF)
        yield from part[:done].splitlines()
        pos += done
        size = window


def count_lines(path, block: int = 1 << 20) -> int:
    """The lines of the file at ``path`` by its line ends (LF, CR LF or CR; at least its rows), read
    1 MB at a time: a file's size in rows before reading it; 0 when it cannot be read (the reader
    then says why)."""
    ends, last = 0, b"\n"
    if not Path(path).is_file():  # a device or a pipe never ends (/dev/zero): the reader says what it is
        return 0
    try:
        with open(path, "rb") as f:
            while chunk := f.read(block):  # LF, CR and CR LF (one end, also across two chunks)
                ends += chunk.count(b"\n") + chunk.count(b"\r") - chunk.count(b"\r\n")
                ends -= last == b"\r" and chunk[:1] == b"\n"
                last = chunk[-1:]
    except OSError:
        return 0
    return ends + (last not in (b"\n", b"\r"))


def csv_rows(lines: Iterable[str], name: str) -> Iterator[list[str]]:
    """The CSV rows of ``lines``, read as they are consumed; a malformed file as one DataError."""
    reader = csv.reader(lines)
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            raise DataError(f"{name}: not a valid CSV file ({exc})") from None
        yield row


def _integer_column(column: str) -> bool:
    return column in INT_COLUMNS or column.startswith("approach")


def cell_value(cell: str, column: str, where: str) -> float:
    """One numeric cell; errors name the line, the column and the value."""
    text = cell.strip()[:40]
    try:
        v = float(cell)
    except ValueError:
        if DECIMAL_COMMA.fullmatch(text):
            raise DataError(f"{where}, column {column}: {text!r} has a decimal comma: robocal reads numbers "
                            "with a decimal point; save the file with '.' as the decimal separator") from None
        raise DataError(f"{where}, column {column}: {text!r} is not a number; fix or remove that "
                        "row") from None
    if not np.isfinite(v):
        raise DataError(f"{where}, column {column}: {text!r} (NaN or infinite); remove failed readings "
                        "or re-import with `robocal import`, which drops them")
    if _integer_column(column) and v != round(v):
        raise DataError(f"{where}, column {column}: {text!r} must be an integer")
    if column in INT_COLUMNS and abs(v) > MAX_INT:
        raise DataError(f"{where}, column {column}: {text!r} is out of range")
    return v


def _skipped(line: str) -> bool:
    """Whether a line is surely one the CSV reading skips: blank, only commas and white space,
    or a ``#`` comment (other skipped rows, e.g. quoted blanks, go the slow way)."""
    return line.lstrip().startswith("#") or not line.replace(",", "").strip()


def _slow_block(lines: list[str], header: list[str], name: str, first_line: int):
    """Values ``(R, C)`` and line numbers ``(R,)`` of a block, cell by cell through the CSV
    reader (the reference reading: quoting, Python's float, an error naming the first bad cell)."""
    width = len(header)
    values, numbers = [], []
    for k, row in enumerate(csv_rows(lines, name)):
        ln = first_line + k
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        if len(row) != width:
            raise DataError(f"{name}, line {ln}: {len(row)} values but the header has {width} columns; "
                            "fix or remove that row")
        where = f"{name}, line {ln}"
        values.append([cell_value(cell, h, where) for h, cell in zip(header, row, strict=True)])
        numbers.append(ln)
    return np.array(values, dtype=float).reshape(len(values), width), np.array(numbers, dtype=np.int64)


def _fast_block(lines: list[str], header: list[str], first_line: int):
    """:func:`_slow_block`'s values and line numbers by numpy's C parser, or None where the block
    needs the slow reading (anything the C parser may take otherwise, or an error to name)."""
    kept = [k for k, line in enumerate(lines) if not _skipped(line)]
    if not kept:
        return np.empty((0, len(header))), np.empty(0, np.int64)
    if any('"' in lines[k] for k in kept):
        return None
    try:
        values = np.loadtxt([lines[k] for k in kept], delimiter=",", comments=None, quotechar=None,
                            dtype=float, ndmin=2)
    except ValueError:
        return None
    if values.shape != (len(kept), len(header)) or not np.isfinite(values).all():
        return None
    for c, h in enumerate(header):
        v = values[:, c]
        if _integer_column(h) and (v != np.round(v)).any():
            return None
        if h in INT_COLUMNS and (np.abs(v) > MAX_INT).any():
            return None
    return values, first_line + np.array(kept, dtype=np.int64)


def read_table(lines: Iterable[str], header: list[str], name: str, header_line: int,
               block_lines: int | None = None):
    """The numeric body ``(R, C)`` of the CSV lines below the header (line ``header_line``) and
    each row's line number ``(R,)`` (blank and ``#`` rows skipped), read ``block_lines`` lines at a
    time (default :data:`BLOCK_LINES`)."""
    blocks, numbers = [], []
    first = header_line + 1
    it = iter(lines)
    while block := list(itertools.islice(it, block_lines or BLOCK_LINES)):
        fast = _fast_block(block, header, first)
        values, line_no = fast if fast is not None else _slow_block(block, header, name, first)
        blocks.append(values)
        numbers.append(line_no)
        first += len(block)
    if not sum(len(b) for b in blocks):
        raise DataError(f"{name}: the file has a header but no data rows")
    return np.concatenate(blocks), np.concatenate(numbers)
