"""Bracketed aggregates of robot program literals, e.g. RAPID ``[[1,2,3],[1,0,0,0],...]`` or URScript
``p[0.1, 0.2, ...]``, parsed into nested lists of :class:`Number` and word tokens with spans."""

from __future__ import annotations

import re
from dataclasses import dataclass

from robocal.core.errors import DataError
from robocal.programs.source import NUMBER_RE, Number, ProgramText


@dataclass(frozen=True, slots=True)
class Word:
    """A non-numeric item (identifier, TRUE/FALSE, a masked string ``"___"``) at ``start``."""

    start: int
    text: str


_TOKEN = re.compile(r"\s*(?:(\[)|(\])|(,)|(" + NUMBER_RE.pattern + r")(?=[\s,\]])|([^\s,\[\]]+))")
_OPEN, _CLOSE, _COMMA, _NUMBER, _WORD_TOKEN = 1, 2, 3, 4, 5


def parse_aggregate(src: ProgramText, masked: str, pos: int, end: int, what: str):
    """Parse the aggregate starting at the '[' at or after ``pos`` (before ``end``) in ``masked``
    (comments/strings blanked). Returns ``(tree, stop)``: nested lists of Number / Word and the
    offset after the closing ']'. Malformed text raises DataError naming file and line."""

    def fail(at: int, why: str):
        raise DataError(f"{src.path.name}:{src.line_of(at)}: malformed {what}: {why}")

    stack: list[list] = [[]]
    expect_item = True  # after '[' or ','
    i = pos
    while True:
        m = _TOKEN.match(masked, i, end)
        if m is None:
            rest = masked[i:end].strip()
            fail(min(i, end), f"unexpected {rest[:1]!r}" if rest else "missing ']'")
        kind, i = m.lastindex, m.end()
        if kind == _OPEN:
            if not expect_item:
                fail(m.start(kind), "expected ',' or ']'")
            stack[-1].append([])
            stack.append(stack[-1][-1])
        elif kind == _CLOSE:
            if len(stack) == 1:
                fail(m.start(kind), "unexpected ']'")
            if expect_item and stack[-1]:
                fail(m.start(kind), "empty item")
            stack.pop()
            expect_item = False
            if len(stack) == 1:
                return stack[0][0], i
        elif kind == _COMMA:
            if expect_item:
                fail(m.start(kind), "empty item")
            expect_item = True
        else:
            if not expect_item or len(stack) == 1:
                fail(m.start(kind), "expected '['" if len(stack) == 1 else "expected ',' or ']'")
            start = m.start(kind)
            item = Number(start, i, src.text[start:i]) if kind == _NUMBER else Word(start, m.group(kind))
            stack[-1].append(item)
            expect_item = False


_SHAPED: dict[tuple[int, ...], re.Pattern] = {}
_ITEM = r"\s*(" + NUMBER_RE.pattern + r")\s*"


def shape_pattern(sizes: tuple[int, ...]) -> re.Pattern:
    """The pattern of an aggregate of lists of ``sizes`` numbers only (a RAPID robtarget
    ``[[x,y,z],[q1..q4],[cf..],[eax..]]`` is (3, 4, 4, 6)), each number a group in order: what
    :func:`parse_aggregate` reads as that tree, found by one compiled match instead of a token
    at a time. Text of another shape does not match (:func:`parse_aggregate` reads it, and names
    what is malformed)."""
    pattern = _SHAPED.get(sizes)
    if pattern is None:
        groups = [r"\[" + ",".join([_ITEM] * k) + r"\]" for k in sizes]
        pattern = _SHAPED[sizes] = re.compile(r"\s*\[\s*" + r"\s*,\s*".join(groups) + r"\s*\]")
    return pattern


def list_pattern(size: int) -> re.Pattern:
    """The pattern of one list of ``size`` numbers (a URScript ``p[x, y, z, rx, ry, rz]``'s
    brackets), each number a group: what :func:`parse_aggregate` reads as a flat list of them."""
    key = (-size,)  # beside the nested shapes of shape_pattern
    pattern = _SHAPED.get(key)
    if pattern is None:
        pattern = _SHAPED[key] = re.compile(r"\s*\[" + ",".join([_ITEM] * size) + r"\]")
    return pattern


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


_SPLITTERS: dict[str, re.Pattern] = {}
_BRACKETS = re.compile(r"[\[\](){}]")


def close_bracket(text: str, open_at: int) -> int:
    """Index of the bracket, brace or parenthesis closing the one at ``open_at``."""
    depth = 0
    for m in _BRACKETS.finditer(text, open_at):  # only the brackets, in C
        if m.group() in "([{":
            depth += 1
        else:
            depth -= 1
            if depth == 0:
                return m.start()
    line = text.count("\n", 0, open_at) + 1
    raise DataError(f"line {line}: unbalanced brackets: the {text[open_at]!r} opened there is never closed")


def split_top(text: str, start: int, end: int, sep: str = ",") -> list[tuple[int, int]]:
    """Spans of ``text[start:end]`` split at ``sep`` (one character) outside brackets, braces and
    parentheses."""
    if _BRACKETS.search(text, start, end) is None:  # nothing nested: split in C
        out, at = [], start
        for piece in text[start:end].split(sep):
            out.append((at, at + len(piece)))
            at += len(piece) + 1
        return out
    splitter = _SPLITTERS.get(sep)
    if splitter is None:
        splitter = _SPLITTERS[sep] = re.compile(r"[\[\](){}" + re.escape(sep) + "]")
    out, depth, last = [], 0, start
    for m in splitter.finditer(text, start, end):  # only the brackets and separators, in C
        ch = m.group()
        if ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif depth == 0:
            out.append((last, m.start()))
            last = m.start() + 1
    out.append((last, end))
    return out
