"""What the filter writes in bulk is what it wrote one item at a time: the number formatter of
its text edits (random values, old numbers of every form the readers accept, the dialects'
resolutions and decimals, negative zero, large and small magnitudes) and the rows of its JSON
table (strings with braces, commas, quotes, control characters)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from robocal.core.errors import DataError
from robocal.programs.aggregate import parse_aggregate, shape_pattern
from robocal.programs.edits import format_numbers
from robocal.programs.result import _one_per_line
from robocal.programs.source import NUMBER_RE, Number, ProgramText, format_number

# the resolutions the dialects write with (mm, deg, quaternion, rad, m) and arbitrary ones
RESOLUTIONS = st.one_of(st.sampled_from([1e-3, 1e-6, 1e-4, 1e-5, 1e-7, 0.01, 0.5, 1.0]),
                        st.floats(1e-9, 10.0))
VALUES = st.one_of(st.floats(-2e3, 2e3), st.sampled_from([0.0, -0.0, -1e-12, 1e-12, -0.0004, 0.0004]),
                   st.floats(allow_nan=False, allow_infinity=False, width=32),
                   st.floats(-1e-6, 1e-6))
OLD = st.from_regex(NUMBER_RE, fullmatch=True).filter(lambda t: len(t) < 40)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(VALUES, OLD, RESOLUTIONS, st.integers(0, 9), st.booleans()), min_size=1,
                max_size=30))
@example([(-0.0, "3", 1e-3, 0, False), (-0.0001, "3", 1e-3, 0, False), (2.5, "+1", 1e-3, 0, False),
          (-0.044, "-.5", 1e-3, 0, False), (0.044, "+.5", 1e-3, 0, False),
          (500.0004, "500.00", 1e-3, 0, False), (1.5e300, "1e3", 1e-6, 4, False),
          (-1e-300, "-0.000", 1e-3, 0, False), (7.0, "6.999", 1e-3, 0, True)])
def test_format_numbers_writes_what_format_number_writes(items):
    """Each number, bulk-formatted among others, gets format_number's text (``near``: the value
    put within a quarter resolution of the old number, where the old text is kept)."""
    values = [float(t) + r / 4 if near else v for v, t, r, _, near in items]
    texts = [t for _, t, _, _, _ in items]
    numbers = [Number(0, len(t), t) for t in texts]
    expected = [format_number(v, n, r, d)
                for v, n, (_, _, r, d, _) in zip(values, numbers, items, strict=True)]
    got = format_numbers(np.array(values), texts, np.array([n.decimals for n in numbers]),
                         np.array([r for _, _, r, _, _ in items]), np.array([d for _, _, _, d, _ in items]))
    assert got == expected


def test_format_numbers_of_nothing():
    """No number: no text."""
    assert format_numbers(np.zeros(0), [], np.zeros(0, int), np.zeros(0), np.zeros(0, int)) == []


SCALARS = st.one_of(st.text(max_size=12), st.sampled_from(["}, {", '"}, {"', "},\x00{", "\x00", "{", "}"]),
                    st.floats(), st.integers(), st.booleans(), st.none())


@settings(max_examples=100, deadline=None)
@given(st.lists(st.dictionaries(st.text(max_size=6), SCALARS, max_size=6), max_size=6))
def test_json_rows_as_dumped_one_by_one(rows):
    """The rows of the table JSON, encoded at once, read as each row's own json.dumps, one a line."""
    assert _one_per_line(rows) == ",".join(f"\n  {json.dumps(row)}" for row in rows)


SPACE = st.sampled_from(["", " ", "  ", "\n", "\t"])


def _number(sign: str, whole: str, point: str, frac: str, exp: str) -> str:
    """A number of any form the readers accept: sign, digits, point, digits, exponent."""
    return sign + (whole or ("" if frac and point else "0")) + point + (frac if point else "") + exp


NUMBER_TEXT = st.builds(_number,
                        st.sampled_from(["", "-", "+"]), st.sampled_from(["", "0", "7", "123", "2600"]),
                        st.sampled_from(["", "."]), st.sampled_from(["", "5", "000", "25"]),
                        st.sampled_from(["", "", "e-3", "E+09", "e5"]))
ITEM = st.one_of(NUMBER_TEXT, NUMBER_TEXT, NUMBER_TEXT, st.sampled_from(["TRUE", "x1", "1.5e", "1x", "[1]"]))


@st.composite
def aggregates(draw):
    """Text of an aggregate of four lists (3, 4, 4, 6 items, now and then one more or less),
    with whitespace anywhere between tokens and now and then an item that is not a number."""
    sizes = [draw(st.sampled_from([k, k, k, k - 1, k + 1])) for k in (3, 4, 4, 6)]

    def sp():
        return draw(SPACE)

    groups = ["[" + sp() + ",".join(sp() + draw(ITEM) + sp() for _ in range(k)) + "]" for k in sizes]
    return sp() + "[" + sp() + ("," + sp()).join(g + sp() for g in groups) + "]" + sp() + ";"


@settings(max_examples=80, deadline=None)
@given(aggregates())
def test_shape_pattern_reads_what_the_token_reader_reads(text):
    """Where the robtarget pattern matches, the token reader gives the same numbers (spans and
    texts) and stops at the same place; where it does not, the token reader refuses the text or
    finds another shape."""
    src = ProgramText("t.mod", text.encode())
    m = shape_pattern((3, 4, 4, 6)).match(text, 0, len(text))
    try:
        tree, stop = parse_aggregate(src, text, 0, len(text), "robtarget")
    except DataError:
        assert m is None
        return
    shaped = [len(g) for g in tree] == [3, 4, 4, 6] and all(isinstance(x, Number) for g in tree for x in g)
    assert (m is not None) == shaped
    if m is not None:
        assert [x for g in tree for x in g] == [Number(a, b, text[a:b]) for a, b in m.regs[1:]]
        assert stop == m.end()


def test_confdata_must_be_integers_of_a_sensible_size(tmp_path):
    """A robtarget's confdata out of any quadrant's range is refused, naming the target."""
    from robocal.programs.registry import dialect_for

    path = tmp_path / "m.mod"
    path.write_text("MODULE m\n  CONST robtarget p1:=[[1,2,3],[1,0,0,0],[0,0,1e999,0],"
                    "[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n")
    with pytest.raises(DataError, match="p1: confdata must be integers"):
        dialect_for([path]).parse([ProgramText(path)], {}, {})
