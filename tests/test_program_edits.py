"""What the filter writes in bulk is what it wrote one item at a time: the number formatter of
its text edits (random values, old numbers of every form the readers accept, the dialects'
resolutions and decimals, negative zero, large and small magnitudes) and the rows of its JSON
table (strings with braces, commas, quotes, control characters)."""

from __future__ import annotations

import json

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from robocal.programs.edits import format_numbers
from robocal.programs.result import _one_per_line
from robocal.programs.source import NUMBER_RE, Number, format_number

# the resolutions the dialects write with (mm, deg, quaternion, rad, m) and arbitrary ones
RESOLUTIONS = st.one_of(st.sampled_from([1e-3, 1e-6, 1e-4, 1e-5, 1e-7, 0.01, 0.5, 1.0]),
                        st.floats(1e-9, 10.0))
VALUES = st.one_of(st.floats(-2e3, 2e3), st.sampled_from([0.0, -0.0, -1e-12, 1e-12, -0.0004, 0.0004]),
                   st.floats(allow_nan=False, allow_infinity=False, width=32),
                   st.floats(-1e-6, 1e-6))
OLD = st.from_regex(NUMBER_RE, fullmatch=True).filter(lambda t: len(t) < 40)


@settings(max_examples=100, deadline=None)
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
