"""Importer: headerless layouts, averaging, failed readings, several SMR files, the real data sets."""

from __future__ import annotations

import numpy as np
import pytest
from robots import require_datasets

from robocal import DataError, UnitError
from robocal.cli import main
from robocal.data import Measurements
from robocal.data.importer import ColumnSpec, import_tracker


def _write(path, rows, sep=","):
    path.write_text("\n".join(sep.join(repr(float(v)) for v in r) for r in rows) + "\n")
    return str(path)


def test_combined_files_average_repeats_and_drop_failed(tmp_path, rng):
    q = rng.uniform(-90, 90, (4, 6))
    p = rng.uniform(-1, 1, (4, 3))
    noise = rng.normal(scale=1e-6, size=(12, 3))
    rows = np.hstack([np.repeat(q, 3, 0), np.repeat(p, 3, 0) + noise, np.zeros((12, 3))])
    rows[4, 6:9] = 0.0  # failed reading (zeros) of pose 1, line 5
    rows[9, 7] = np.nan  # NaN of pose 3, line 10
    f1 = _write(tmp_path / "a.csv", rows)
    f2 = _write(tmp_path / "b.txt", rows[:3], sep=" ")
    res = import_tracker([f1, f2], joints="cols=0-5:deg", points="cols=6-8:m")
    d = res.data
    assert d.n_poses == 5 and len(d) == 5 and d.pose_id.tolist() == [0, 1, 2, 3, 4]
    assert [(f.split("/")[-1], ln) for f, ln, _ in res.dropped] == [("a.csv", 5), ("a.csv", 10)]
    np.testing.assert_allclose(d.joints[:4], np.deg2rad(q))
    good = np.ones(12, bool)
    good[[4, 9]] = False
    expect = np.array([rows[:12][good & (np.arange(12) // 3 == k)][:, 6:9].mean(0) for k in range(4)])
    np.testing.assert_allclose(d.points[:4], expect, rtol=0, atol=1e-15)
    assert d.source_row.tolist() == [1, 4, 7, 11, 1]  # line 10 failed: first valid reading
    assert res.readings.tolist() == [3, 2, 3, 2, 3]
    dev = np.linalg.norm(rows[0:3, 6:9] - rows[0:3, 6:9].mean(0), axis=1)
    assert res.spread_max[0] == pytest.approx(dev.max(), abs=1e-15)
    assert res.spread_rms[0] == pytest.approx(np.sqrt(np.mean(dev**2)), abs=1e-15)
    text = res.summary()
    assert "5 poses" in text and "line 5" in text and "line 10" in text and "spread max" in text
    keep = import_tracker([f1], joints="cols=0-5:deg", points="cols=6-8:m", average=False).data
    assert len(keep) == 10 and keep.n_poses == 4
    assert keep.pose_id.tolist() == [0, 0, 0, 1, 1, 2, 2, 2, 3, 3]


@pytest.mark.parametrize("average", [True, False])
def test_each_combined_file_is_a_run_of_its_own(tmp_path, rng, average):
    """A file's first pose follows no row of another file: its approach and move are 0 (unknown),
    the other rows' are those of their own file's order (backlash and travel terms use them)."""
    q = rng.uniform(-90, 90, (7, 6))
    rows = np.hstack([np.repeat(q, 2, 0), rng.uniform(-1, 1, (14, 3)), np.zeros((14, 3))])
    files = [_write(tmp_path / "run1.csv", rows[:8]), _write(tmp_path / "run2.csv", rows[8:])]
    together = import_tracker(files, joints="cols=0-5:deg", points="cols=6-8:m", average=average).data
    alone = [import_tracker([f], joints="cols=0-5:deg", points="cols=6-8:m", average=average).data
             for f in files]
    np.testing.assert_array_equal(together.approach, np.vstack([d.approach for d in alone]))
    np.testing.assert_allclose(together.travel, np.vstack([d.travel for d in alone]), rtol=0, atol=1e-15)
    first_of_run2 = len(alone[0])
    assert not together.approach[first_of_run2].any() and not together.travel[first_of_run2].any()
    moved = np.sign(q[5] - q[4])  # the second pose of run 2 came from its first one
    np.testing.assert_array_equal(together.approach[first_of_run2 + (1 if average else 2)], moved)


def test_separate_smr_files_in_mm(tmp_path, rng):
    q = rng.uniform(-3, 3, (5, 6))
    pts = rng.uniform(-2000, 2000, (3, 5, 3))
    pts[1, 2] = 0.0  # SMR 2 failed at pose 2
    jf = _write(tmp_path / "joints.txt", q, sep=" ")
    pfs = [_write(tmp_path / f"smr{s}.txt", pts[s], sep=" ") for s in range(3)]
    base = _write(tmp_path / "base.txt", np.vstack([[[1000.0, 0, 0]] * 4, [[1000.03, 0, 0]], [[0, 0, 0]]]))
    res = import_tracker(joints=f"{jf}:cols=0-5:rad", points=[f"{p}:mm" for p in pfs], base=[f"{base}:mm"])
    d = res.data
    assert len(d) == 14 and d.n_poses == 5 and d.n_smr == 3
    assert d.smr.tolist() == [0, 1, 2, 0, 1, 2, 0, 2, 0, 1, 2, 0, 1, 2]
    assert d.pose_id.tolist() == [0, 0, 0, 1, 1, 1, 2, 2, 3, 3, 3, 4, 4, 4]
    np.testing.assert_allclose(d.points[d.smr == 2], pts[2] * 1e-3)
    np.testing.assert_array_equal(d.joints[d.smr == 0], q)
    assert res.dropped[0][1] == 3 and res.dropped[0][0].endswith("smr1.txt")
    assert res.drift[0]["max_mm"] == pytest.approx(0.03, abs=1e-9) and res.drift[0]["dropped"] == 1


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"joints": "cols=0-5", "points": "cols=6-8:m"}, UnitError, "state the unit"),
        ({"joints": "cols=0-5:mm", "points": "cols=6-8:m"}, UnitError, "not a joints unit"),
        ({"joints": "cols=0-5:deg", "points": "cols=6-7:m"}, DataError, "exactly 3"),
        ({"joints": "cols=0-5:deg", "points": "cols=6-9x:m"}, DataError, "columns must be"),
        ({"joints": "cols=0-5:deg", "points": "cols=20-22:m"}, DataError, "only 12 columns"),
    ],
)
def test_bad_specs(tmp_path, rng, kwargs, error, match):
    f = _write(tmp_path / "a.csv", rng.normal(size=(3, 12)))
    with pytest.raises(error, match=match):
        import_tracker([f], **kwargs)


def test_bad_raw_files(tmp_path):
    (tmp_path / "h.csv").write_text("q1,q2\n1,2\n")
    with pytest.raises(DataError, match="line 1.*skip-rows"):
        import_tracker([tmp_path / "h.csv"], joints="cols=0-1:deg", points="cols=0-2:m")
    (tmp_path / "r.csv").write_text("1,2,3\n1,2\n")
    with pytest.raises(DataError, match="line 2"):
        import_tracker([tmp_path / "r.csv"], joints="cols=0-1:deg", points="cols=0-2:m")
    assert ColumnSpec.parse("C:/data/j.txt:cols=0-5:deg", "joints").file == "C:/data/j.txt"


def test_cli_imports_real_data_sets(tmp_path, capsys):
    ds = require_datasets()
    meca = ds / "meca500-faro"
    for part, poses in (("cal", 490), ("val", 70)):
        files = sorted(str(p) for p in meca.glob(f"{part}_data__*_Output.csv"))
        out = tmp_path / f"meca_{part}.csv"
        assert (
            main(["import", *files, "--joints", "cols=0-5:deg", "--points", "cols=6-8:m", "-o", str(out)])
            == 0
        )
        d = Measurements.load(out)
        assert d.n_poses == poses and len(d) == poses
    irb = ds / "irb120-faro"
    out = tmp_path / "irb120.csv"
    args = ["import", "--joints", f"{irb}/measured_joints.txt:cols=0-5:deg"]
    for s in (1, 2, 3):
        args += ["--points", f"{irb}/measured_SMR_{s}.txt:mm", "--base", f"{irb}/measured_base_{s}.txt:mm"]
    assert main([*args, "-o", str(out)]) == 0
    d = Measurements.load(out)
    assert d.n_poses == 1000 and len(d) == 3000 and np.bincount(d.smr).tolist() == [1000] * 3
    assert "base SMR drift" in capsys.readouterr().out
