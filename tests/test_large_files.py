"""Large measurement files: the CSV read block by block gives exactly what one block (and the
cell-by-cell reading) gives, the residual test's shuffles give the same statistics in any batch, and
an evaluation that cannot fit in memory is refused before it starts with one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import robocal as rc
import robocal.core.resources as res
import robocal.data.csv_table as ct
import robocal.trust.consistency as tc
from robocal.cli import main
from robocal.core.errors import DataError, ResourceError
from robocal.data.measurements import parse_csv
from robocal.data.simulate import simulate_tracker

HEADER = ["pose_id", "q1_deg", "q2_deg", "x_mm", "smr"]


@settings(max_examples=60, deadline=None)
@given(st.text(alphabet="ab,#\r\n\x0b\x1c\u2028 ", max_size=80), st.integers(1, 9))
def test_lines_are_those_of_splitlines_in_any_window(text, window):
    assert list(ct.text_lines(text, window)) == text.splitlines()


def _formatted(v: float, style: int) -> str:
    """A number as files write it: repr, fixed, scientific, padded, with an underscore, quoted."""
    return [repr(v), f"{v:.3f}", f"{v:.6e}", f"  {v!r} ", f'"{v!r}"', f"{v:_.1f}"][style]


@st.composite
def _csv_body(draw):
    n = draw(st.integers(1, 40))
    lines = []
    for k in range(n):
        kind = draw(st.sampled_from(["row"] * 6 + ["blank", "comment", "commas", "quoted"]))
        if kind == "blank":
            lines.append(draw(st.sampled_from(["", "   "])))
        elif kind == "comment":
            lines.append("# a note, 1, 2")
        elif kind == "commas":
            lines.append(" , ,,")
        else:
            q = draw(st.lists(st.floats(-170, 170, allow_nan=False), min_size=2, max_size=2))
            x = draw(st.floats(-3000, 3000, allow_nan=False))
            styles = draw(st.lists(st.integers(0, 5 if kind == "quoted" else 3), min_size=3, max_size=3))
            cells = [str(k), *(_formatted(v, s) for v, s in zip([*q, x], styles, strict=True)), "0"]
            lines.append(",".join(cells))
    return lines


@settings(max_examples=60, deadline=None)
@given(_csv_body(), st.integers(1, 7))
def test_blocks_of_any_size_read_what_one_block_and_the_cell_by_cell_reading_read(lines, block):
    rows = [ln for ln in lines if not (ln.lstrip().startswith("#") or not ln.replace(",", "").strip())]
    if not rows:
        with pytest.raises(DataError, match="no data rows"):
            ct.read_table(lines, HEADER, "f.csv", 1, block)
        return
    values, line_no = ct.read_table(lines, HEADER, "f.csv", 1, block)
    one, one_no = ct.read_table(lines, HEADER, "f.csv", 1, len(lines))
    slow, slow_no = ct._slow_block(lines, HEADER, "f.csv", 2)  # the reference reading
    assert np.array_equal(values, one) and np.array_equal(values, slow)
    assert np.array_equal(line_no, one_no) and np.array_equal(line_no, slow_no)
    assert values.shape == (len(rows), len(HEADER))


def test_a_bad_cell_in_a_late_block_is_named_as_with_one_block():
    lines = [f"{k},1.5,2.5,100.0,0" for k in range(20)]
    assert ct._fast_block(lines, HEADER, 2) is not None  # plain rows take numpy's C parser
    lines[13] = "13,1.5,abc,100.0,0"
    messages = []
    for block in (1, 4, 100):
        with pytest.raises(DataError) as err:
            ct.read_table(lines, HEADER, "f.csv", 1, block)
        messages.append(str(err.value))
    assert len(set(messages)) == 1 and "line 15, column q2_deg: 'abc' is not a number" in messages[0]


def test_a_whole_file_reads_the_same_in_small_blocks_and_windows(monkeypatch):
    sim = simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 50, noise_mm=0.02, seed=4)
    text = sim.data.to_csv().replace("\n", "\r\n", 7)  # mixed line ends too
    whole = parse_csv(text, "d.csv")
    monkeypatch.setattr(ct, "BLOCK_LINES", 3)
    monkeypatch.setattr(ct, "WINDOW_CHARS", 50)
    small = parse_csv(text, "d.csv")
    for field in ("joints", "points", "pose_id", "smr", "source_row", "approach", "travel"):
        assert np.array_equal(getattr(small, field), getattr(whole, field)), field
    assert np.array_equal(whole.points, sim.data.points) and whole.source == small.source


def test_shuffles_give_the_same_statistics_in_batches_of_any_size(monkeypatch):
    rng = np.random.default_rng(2)
    errors = rng.normal(size=(300, 3)) * 2e-5
    errors[180:] += 4e-5  # a step: reported, with its p-value from the shuffles
    from scipy.spatial.transform import Rotation

    R = Rotation.random(300, random_state=3).as_matrix()
    cusum = tc._cusum
    results = {}
    for batch in (1, 7, 20):
        seen = []
        monkeypatch.setattr(tc, "_permutation_batch", lambda n, b=batch: b)
        monkeypatch.setattr(tc, "_cusum", lambda X, s, seen=seen: seen.append(cusum(X, s)) or seen[-1])
        found = tc.change_point(errors, R, 1e-6, seed=5)
        stats = np.concatenate(seen[1:], axis=1)  # (frames, shuffles, splits)
        results[batch] = (found, stats)
    assert results[1][0] is not None and results[1][0][0] == 180
    for batch in (7, 20):
        assert results[batch][0] == results[1][0]
        assert results[batch][1].shape == (2, tc.PERMUTATIONS, 300 - 2 * 15 + 1)
        assert np.array_equal(results[batch][1], results[1][1])


def test_the_batch_bounds_the_shuffles_memory():
    assert tc._permutation_batch(100) == tc._PERMUTATION_BATCH
    assert tc._permutation_batch(10_000_000) == 1
    n = 50_000
    assert tc._permutation_batch(n) * 2 * n * 3 * tc._CUSUM_BYTES_PER_VALUE <= max(
        tc._PERMUTATION_BYTES, 2 * n * 3 * tc._CUSUM_BYTES_PER_VALUE)


@pytest.fixture
def short_of_memory(monkeypatch, tmp_path):
    """A 30-pose simulated campaign saved as d.csv and its truth m.yaml in ``tmp_path``, on a
    machine that offers 0.2 GB."""
    robot = rc.Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(robot, 30, noise_mm=0.02, seed=1)
    sim.data.save(tmp_path / "d.csv")
    sim.truth.save(tmp_path / "m.yaml")
    monkeypatch.setattr(res, "available_bytes", lambda: 200_000_000)
    return sim


def test_an_evaluation_that_cannot_fit_is_refused_before_it_starts(short_of_memory, monkeypatch, tmp_path,
                                                                   capsys):
    sim = short_of_memory
    with pytest.raises(ResourceError, match=r"evaluating 30 measurement rows needs about 0\.30 GB.*"
                                            r"offers 0\.20 GB.*evaluate a subset"):
        rc.evaluate(sim.truth, sim.data)
    code = main(["--quiet", "evaluate", str(tmp_path / "m.yaml"), str(tmp_path / "d.csv"),
                 "--json", str(tmp_path / "e.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "needs about" in err[0] and not (tmp_path / "e.json").exists()
    monkeypatch.setattr(res, "available_bytes", lambda: None)  # unknown: it runs
    assert main(["--quiet", "evaluate", str(tmp_path / "m.yaml"), str(tmp_path / "d.csv"),
                 "--json", str(tmp_path / "e.json")]) == 0
    written = json.loads((tmp_path / "e.json").read_text())
    stats = rc.evaluate(sim.truth, sim.data)
    assert written["errors_mm"] == stats["errors_mm"].tolist()
    assert written["evaluation"]["rms"] == stats["rms"]
    assert res.evaluation_bytes(1000) - res.evaluation_bytes(0) == 1000 * res.EVALUATION_BYTES_PER_ROW


@settings(max_examples=30, deadline=None)
@given(st.integers(12, 400), st.integers(1, 4), st.integers(0, 2**32 - 1))
def test_the_cusum_is_bit_identical_to_its_formula(n, shuffles, seed):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(2, n, 3)) * 1e-5 + rng.normal(size=3) * 1e-4
    shuffled = np.take(X, np.argsort(rng.random((shuffles, n)), axis=1), axis=1)
    m = max(tc.MIN_SEGMENT_ROWS, int(tc.MIN_SEGMENT_FRACTION * n))
    splits = np.arange(m, n - m + 1)
    for Y in (X, shuffled):
        S = np.cumsum(Y - Y.mean(axis=-2, keepdims=True), axis=-2)[..., splits - 1, :]
        assert np.array_equal(tc._cusum(Y, splits), np.sum(S**2, axis=-1) / (splits * (n - splits) / n))


@settings(max_examples=40, deadline=None)
@given(st.text(alphabet="ab,\r\n", max_size=60), st.integers(1, 5))
def test_the_line_count_before_reading_covers_every_row(tmp_path_factory, text, block):
    path = tmp_path_factory.mktemp("lines") / "f.csv"
    path.write_bytes(text.encode())
    lines = text.splitlines()
    n = ct.count_lines(path, block)
    assert len(lines) <= n <= text.count("\n") + text.count("\r") + 1


def test_the_command_refuses_a_file_too_large_before_reading_it(short_of_memory, monkeypatch, tmp_path,
                                                                 capsys):
    def not_read(*args, **kwargs):
        raise AssertionError("the file was read before the refusal")

    monkeypatch.setattr("robocal.cli.args.load_measurements", not_read)
    code = main(["--quiet", "evaluate", str(tmp_path / "m.yaml"), str(tmp_path / "d.csv")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "evaluating 32 measurement rows needs about 0.30 GB" in err[0] and "evaluate a subset" in err[0]
