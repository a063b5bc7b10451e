"""Bracketed aggregates of robot program literals, e.g. RAPID ``[[1,2,3],[1,0,0,0],...]`` or URScript
``p[0.1, 0.2, ...]``, parsed into nested lists of :class:`Number` and word tokens with spans."""

from __future__ import annotations

import re
from dataclasses import dataclass

from robocal.errors import DataError
from robocal.programs.source import NUMBER_RE, Number, ProgramText

_WORD = re.compile(r"[^\s,\[\]]+")


@dataclass(frozen=True)
class Word:
    """A non-numeric item (identifier, TRUE/FALSE, a masked string ``"___"``) at ``start``."""

    start: int
    text: str


def parse_aggregate(src: ProgramText, masked: str, pos: int, end: int, what: str):
    """Parse the aggregate starting at the '[' at or after ``pos`` (before ``end``) in ``masked``
    (comments/strings blanked). Returns ``(tree, stop)``: nested lists of Number / Word and the
    offset after the closing ']'. Malformed text raises DataError naming file and line."""

    def fail(at: int, why: str):
        raise DataError(f"{src.path.name}:{src.line_of(at)}: malformed {what}: {why}")

    def skip(i: int) -> int:
        while i < end and masked[i].isspace():
            i += 1
        return i

    def item(i: int):
        i = skip(i)
        if i >= end:
            fail(i, "unexpected end")
        if masked[i] == "[":
            return seq(i)
        m = NUMBER_RE.match(masked, i, end)
        if m and (m.end() >= end or masked[m.end()] in " \t\r\n,]"):
            return Number(m.start(), m.end(), src.text[m.start():m.end()]), m.end()
        m = _WORD.match(masked, i, end)
        if m:
            return Word(m.start(), m.group()), m.end()
        fail(i, "empty item" if masked[i] in ",]" else f"unexpected {masked[i]!r}")

    def seq(i: int):
        out = []
        i = skip(i + 1)
        if i < end and masked[i] == "]":
            return out, i + 1
        while True:
            node, i = item(i)
            out.append(node)
            i = skip(i)
            if i >= end:
                fail(i, "missing ']'")
            if masked[i] == ",":
                i += 1
                continue
            if masked[i] == "]":
                return out, i + 1
            fail(i, f"expected ',' or ']', found {masked[i]!r}")

    start = skip(pos)
    if start >= end or masked[start] != "[":
        fail(start, "expected '['")
    return seq(start)


def numbers_of(node, sizes: tuple[int, ...], src: ProgramText, at: int, what: str) -> list[list[Number]]:
    """Check that ``node`` is a list of lists of numbers of the given sizes; return them."""
    ok = isinstance(node, list) and len(node) >= len(sizes)
    if ok:
        for part, size in zip(node, sizes, strict=False):
            numbers = isinstance(part, list) and all(isinstance(x, Number) for x in part)
            if not (numbers and len(part) == size):
                ok = False
    if not ok:
        raise DataError(f"{src.path.name}:{src.line_of(at)}: malformed {what}: expected groups of "
                        f"{', '.join(map(str, sizes))} numbers")
    return [node[k] for k in range(len(sizes))]


def split_top(text: str, start: int, end: int, sep: str = ",") -> list[tuple[int, int]]:
    """Spans of ``text[start:end]`` split at ``sep`` outside brackets, braces and parentheses."""
    out, depth, last = [], 0, start
    for i in range(start, end):
        ch = text[i]
        if ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif ch == sep and depth == 0:
            out.append((last, i))
            last = i + 1
    out.append((last, end))
    return out
