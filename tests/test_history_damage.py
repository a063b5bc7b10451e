"""A history that checks what it reads: damaged files (a scrambled index, an overwritten page),
records with wrong types or broken JSON, read-only files and folders, another application's SQLite
file and a full disk, each built here, through the CLI and the API. Every refusal is one line (exit
2) naming its cause; no input changes and no record is lost."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import shutil
import sqlite3
import subprocess
import uuid

import numpy as np
import pytest
from test_history import postgres_url  # noqa: F401  (the fixture, used by name)

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import sample_joints, simulate_tracker
from robocal.history.store import BadRecordError, History, Record, validate_row
from robocal.history.timeline import read_timeline

ROBOT = "R1"
MOUNT_TIMEOUT_S = 30  # mount/umount of a small tmpfs: seconds, never waited on without a deadline


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A real history (calibrate, then check, through the CLI) with the model and data it used."""
    folder = tmp_path_factory.mktemp("made")
    nominal = rc.Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(nominal, 60, seed=21)
    sim.data.save(folder / "cal.csv")
    joints = sample_joints(sim.truth, 20, np.random.default_rng(3))
    simulate_tracker(sim.truth, joints=joints, as_is=True, seed=3).data.save(folder / "check.csv")
    hist = folder / "h.sqlite"
    assert main(["--quiet", "calibrate", str(folder / "cal.csv"), "--robot", "abb_irb2600", "--nongeometric",
                 "none", "-o", str(folder / "cal.yaml"), "--history", str(hist), "--robot-id", ROBOT]) == 0
    assert main(["--quiet", "check", str(folder / "cal.yaml"), str(folder / "check.csv"), "--history",
                 str(hist), "--robot-id", ROBOT]) == 0
    return folder


@pytest.fixture
def hist(made, tmp_path):
    """A fresh copy of the made history in this test's folder."""
    path = tmp_path / "h.sqlite"
    shutil.copy(made / "h.sqlite", path)
    return path


def _sha(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _rows(path) -> list[int]:
    """The record ids in the table itself (a full scan: no index)."""
    with contextlib.closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as conn:
        return [r[0] for r in conn.execute("SELECT id FROM records NOT INDEXED ORDER BY id")]


def _page(path, name: str) -> int:
    """The byte offset of the root page of table or index ``name``."""
    with contextlib.closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as conn:
        root = conn.execute("SELECT rootpage FROM sqlite_master WHERE name = ?", (name,)).fetchone()[0]
        size = conn.execute("PRAGMA page_size").fetchone()[0]
    return (root - 1) * size


def _scramble_index(path, count: int = -1) -> None:
    """Change ``count`` (default all) robot id keys stored in the index page (the table keeps its rows)."""
    at = _page(path, "records_robot")
    with open(path, "r+b") as f:
        f.seek(at)
        page = f.read(4096)
        f.seek(at)
        f.write(page.replace(ROBOT.encode(), b"Q7", count))


def _sql(path, sql: str) -> None:
    with contextlib.closing(sqlite3.connect(path)) as conn, conn:
        conn.execute(sql)


def _cli(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("journal", ["delete", "wal"])  # wal: as an earlier robocal left its histories
def test_a_scrambled_index_is_found_and_the_history_is_never_written(made, hist, tmp_path, capsys, journal):
    with contextlib.closing(sqlite3.connect(hist)) as conn:
        conn.execute(f"PRAGMA journal_mode={journal}")
    _scramble_index(hist)
    before, ids = _sha(hist), _rows(hist)
    assert ids == [1, 2]
    with pytest.raises(DataError, match="is damaged .*integrity check: row 1 missing from index"):
        History(hist, readonly=True).entries(ROBOT)  # the lookup finds nothing: the check says why
    with pytest.raises(DataError, match="is damaged"):
        History(hist)  # a write open checks first
    code, _, err = _cli(capsys, "history", hist, "--robot-id", ROBOT)
    assert code == 2 and "damaged" in err and "missing from index records_robot" in err
    out = tmp_path / "eval.json"
    code, _, err = _cli(capsys, "evaluate", made / "cal.yaml", made / "check.csv", "--fit-frame", "--history",
                        hist, "--robot-id", ROBOT, "--json", out)
    assert code == 2 and "damaged" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()  # refused before any output
    code, _, err = _cli(capsys, "check", made / "cal.yaml", made / "check.csv", "--history", hist,
                        "--robot-id", ROBOT)
    assert code == 2 and "damaged" in err
    assert _sha(hist) == before and _rows(hist) == ids  # no write, no record lost


def test_an_index_that_hides_one_record_is_found(made, hist, capsys):
    _scramble_index(hist, 1)  # the lookup still finds a record: the table count tells
    before = _sha(hist)
    with pytest.raises(DataError, match="is damaged .*missing from index records_robot"):
        History(hist, readonly=True).entries(ROBOT)
    code, _, err = _cli(capsys, "history", hist, "--robot-id", ROBOT)
    assert code == 2 and "damaged" in err
    assert _sha(hist) == before and _rows(hist) == [1, 2]


def test_an_overwritten_page_is_reported_as_damage(made, hist, capsys):
    at = _page(hist, "records")
    with open(hist, "r+b") as f:
        f.seek(at + 8)
        f.write(b"\xff" * 64)
    before = _sha(hist)
    for argv in (("history", hist, "--robot-id", ROBOT),
                 ("check", made / "cal.yaml", made / "check.csv", "--history", hist, "--robot-id", ROBOT)):
        code, _, err = _cli(capsys, *argv)
        assert code == 2 and "is damaged (SQLite integrity check:" in err and "internal error" not in err
    with pytest.raises(DataError, match="damaged"):
        History(hist, readonly=True).entries(ROBOT)
    assert _sha(hist) == before


@pytest.mark.parametrize("sql, message", [
    ("UPDATE schema_version SET version = 'one'", "damaged schema version .*'one' of type str"),
    ("INSERT INTO schema_version VALUES (1)", r"damaged schema version \(2 row"),
])
def test_a_bad_schema_version_is_refused(made, hist, capsys, sql, message):
    _sql(hist, sql)
    before = _sha(hist)
    for readonly in (True, False):
        with pytest.raises(DataError, match=message):
            History(hist, readonly=readonly)
    code, _, err = _cli(capsys, "check", made / "cal.yaml", made / "check.csv", "--history", hist,
                        "--robot-id", ROBOT)
    assert code == 2 and "schema version" in err
    assert _sha(hist) == before


@pytest.mark.parametrize("sql, cause", [
    ("UPDATE records SET summary = '{\"rms\": 0.1' WHERE id = 2", "record #2: its summary is not JSON"),
    ("UPDATE records SET summary = json_set(summary, '$.p_value', '0.288') WHERE id = 2",
     r"record #2: its summary.p_value: expected a number, got '0.288'"),
    ("UPDATE records SET summary = json_set(summary, '$.p_value', 1.5) WHERE id = 2",
     "record #2: a check needs a verdict .* p-value in"),
    ("UPDATE records SET summary = '[1, 2]' WHERE id = 2", "record #2: its summary is JSON list, not dict"),
    ("UPDATE records SET data = X'0102' WHERE id = 2", "record #2: its data is bytes"),
    ("UPDATE records SET model_yaml = model_yaml || ' ' WHERE id = 2", "record #2: its model does not match"),
    ("UPDATE records SET recorded_at = 'yesterday' WHERE id = 2", "record #2: its date 'yesterday'"),
    ("UPDATE records SET summary = json_set(summary, '$.changed_parameters', json('[{\"name\": \"a2\"}]')) "
     "WHERE id = 2", r"record #2: its summary.changed_parameters\[0\]: missing field 'unit'"),
    ("UPDATE records SET data = json_set(data, '$[0].sha256', 7) WHERE id = 2",
     r"record #2: its data\[0\].sha256: expected a text, got 7"),
])
def test_a_bad_check_record_is_left_out_of_the_timeline_with_a_warning(made, hist, tmp_path, capsys, sql,
                                                                       cause):
    _sql(hist, sql)
    with pytest.raises(DataError, match=cause):  # a command that uses the records refuses
        History(hist, readonly=True).entries(ROBOT)
    skipped: list[str] = []
    assert [r.id for r in History(hist, readonly=True).entries(ROBOT, skipped=skipped)] == [1]
    assert len(skipped) == 1
    timeline = read_timeline(str(hist), ROBOT)
    assert [e["id"] for e in timeline.entries] == [1] and timeline.warnings == skipped
    out, page = tmp_path / "timeline.json", tmp_path / "history.html"
    code, text, err = _cli(capsys, "history", hist, "--robot-id", ROBOT, "--json", out, "--report", page)
    assert code == 0 and "WARNING: left out record #2" in text
    written = json.loads(out.read_text())
    assert [e["id"] for e in written["entries"]] == [1] and written["warnings"] == skipped
    assert "1 unreadable left out" in page.read_text()
    # check needs only the calibration (#1), which is sound: it runs
    code, _, err = _cli(capsys, "check", made / "cal.yaml", made / "check.csv", "--history", hist,
                        "--robot-id", ROBOT)
    assert code == 0, err
    assert _rows(hist) == [1, 2, 3]  # recorded after the others, none lost


@pytest.mark.parametrize("sql, cause", [
    ("UPDATE records SET uncertainty = NULL WHERE id = 1",
     "calibration #1 of robot id 'R1' has no uncertainty"),
    ("UPDATE records SET uncertainty = json_set(uncertainty, '$.noise_m', 'x') WHERE id = 1",
     "record #1: its uncertainty's noise_m is 'x'"),
    ("UPDATE records SET uncertainty = json_remove(uncertainty, '$.covariance[0]') WHERE id = 1",
     "record #1: its uncertainty's covariance is not a finite"),
    ("UPDATE records SET summary = 'NaN' WHERE id = 1", "record #1: its summary is JSON float"),
    ("UPDATE records SET parent_id = 'one' WHERE id = 1", "record #1: its parent_id is 'one'"),
])
def test_a_bad_calibration_record_makes_check_refuse_by_its_cause(made, hist, tmp_path, capsys, sql, cause):
    _sql(hist, sql)
    before = _sha(hist)
    out = tmp_path / "check.json"
    code, _, err = _cli(capsys, "check", made / "cal.yaml", made / "check.csv", "--history", hist,
                        "--robot-id", ROBOT, "--json", out)
    assert code == 2 and "internal error" not in err, err
    assert len(err.strip().splitlines()) == 1 and re.search(cause, err), err
    if "no uncertainty" not in cause:  # evaluate reads the calibration after its outputs: it checks first
        code, _, err = _cli(capsys, "evaluate", made / "cal.yaml", made / "check.csv", "--fit-frame",
                            "--history", hist, "--robot-id", ROBOT, "--json", out)
        assert code == 2 and re.search(cause, err), err
    assert not out.exists() and _sha(hist) == before


def test_validate_row_names_each_fault():
    model = "name: r\n"
    good = (1, ROBOT, "check", "2026-01-02T03:04:05.678+00:00", "0.1.0", model,
            hashlib.sha256(model.encode()).hexdigest(), json.dumps({"verdict": "holds", "p_value": 0.3}),
            "[]", None, "[]", None)
    assert validate_row(good, ROBOT, None).summary["p_value"] == 0.3
    faults = ((0, "1", "its id is '1'"), (1, "R2", "robot id 'R2' .*damaged index"), (2, "evaluation", None),
              (7, '{"verdict": "holds", "p_value": true}', "summary.p_value: expected a number, got True"),
              (7, '{"verdict": "holds", "p_value": 0.3, "rms_mm": "0.1"}', "rms_mm"),
              (9, '{"names": ["a"], "covariance": [[1]], "noise_m": 1e-5, "dof": 0}', "dof"),
              (11, 1.5, "parent_id"))
    for index, value, cause in faults:
        row = list(good)
        row[index] = value
        if cause is None:  # a different kind than asked
            with pytest.raises(BadRecordError, match="damaged index"):
                validate_row(tuple(row), ROBOT, "check")
            continue
        with pytest.raises(BadRecordError, match=cause):
            validate_row(tuple(row), ROBOT, None)


def test_a_read_only_history_is_refused_before_any_output_and_read_without_change(made, hist, tmp_path,
                                                                                  capsys):
    os.chmod(hist, 0o444)
    try:
        before, listing = _sha(hist), sorted(os.listdir(tmp_path))
        out = tmp_path / "eval.json"
        code, _, err = _cli(capsys, "evaluate", made / "cal.yaml", made / "check.csv", "--fit-frame",
                            "--history", hist, "--robot-id", ROBOT, "--json", out)
        assert code == 2 and "the file is read-only" in err and not out.exists()
        code, _, err = _cli(capsys, "check", made / "cal.yaml", made / "check.csv", "--history", hist,
                            "--robot-id", ROBOT, "--json", out)
        assert code == 2 and "the file is read-only" in err and not out.exists()
        with pytest.raises(DataError, match="read-only"):
            History(hist)
        code, text, err = _cli(capsys, "history", hist, "--robot-id", ROBOT)
        assert code == 0 and "#2" in text
        with History(hist, readonly=True) as h:
            assert [r.id for r in h.entries(ROBOT)] == [1, 2]
            with pytest.raises(DataError, match="opened read-only"):
                h.record(Record(robot_id=ROBOT, kind="evaluation", model_yaml="name: r\n", summary={}))
        assert _sha(hist) == before and sorted(os.listdir(tmp_path)) == listing  # nothing created beside it
    finally:
        os.chmod(hist, 0o644)


@contextlib.contextmanager
def _read_only_folder(tmp_path, source):
    """A folder holding a copy of the history ``source`` that cannot be written even by root: a
    read-only tmpfs when running as root (skip when it cannot be mounted), else a folder chmod 555."""
    folder = tmp_path / "ro"
    folder.mkdir()
    if os.geteuid() != 0:
        shutil.copy(source, folder / "h.sqlite")
        folder.chmod(0o555)
        try:
            yield folder / "h.sqlite"
        finally:
            folder.chmod(0o755)
        return
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4m", "tmpfs", str(folder)],
                      capture_output=True, timeout=MOUNT_TIMEOUT_S).returncode:
        pytest.skip("root without a tmpfs mount: a read-only folder cannot be made")
    try:
        shutil.copy(source, folder / "h.sqlite")
        subprocess.run(["mount", "-o", "remount,ro", str(folder)], check=True, capture_output=True,
                       timeout=MOUNT_TIMEOUT_S)
        yield folder / "h.sqlite"
    finally:  # detached even when a connection still holds it (a later run's cleanup then succeeds)
        if subprocess.run(["umount", str(folder)], capture_output=True, timeout=MOUNT_TIMEOUT_S).returncode:
            subprocess.run(["umount", "-l", str(folder)], capture_output=True, timeout=MOUNT_TIMEOUT_S)


@pytest.mark.parametrize("journal", ["delete", "wal"])  # wal: opened immutable (no writer can be there)
def test_a_history_in_a_read_only_folder_is_read(made, hist, tmp_path, capsys, journal):
    with contextlib.closing(sqlite3.connect(hist)) as conn:
        conn.execute(f"PRAGMA journal_mode={journal}")
    with _read_only_folder(tmp_path, hist) as hist:
        code, text, err = _cli(capsys, "history", hist, "--robot-id", ROBOT)
        assert code == 0 and "#1" in text and "#2" in text, err
        code, _, err = _cli(capsys, "check", made / "cal.yaml", made / "check.csv", "--history", hist,
                            "--robot-id", ROBOT)
        assert code == 2 and ("not writable" in err or "read-only" in err), err
        assert os.listdir(hist.parent) == ["h.sqlite"]


def test_another_applications_sqlite_file_is_never_touched(made, tmp_path, capsys):
    other = tmp_path / "other.sqlite"
    with contextlib.closing(sqlite3.connect(other)) as conn, conn:
        conn.execute("CREATE TABLE customers (name TEXT)")
        conn.execute("INSERT INTO customers VALUES ('ACME')")
    before = _sha(other)
    for readonly in (True, False):
        with pytest.raises(DataError, match=r"not a robocal history: .*application \(tables customers\)"):
            History(other, readonly=readonly)
    out = tmp_path / "eval.json"
    code, _, err = _cli(capsys, "evaluate", made / "cal.yaml", made / "check.csv", "--fit-frame", "--history",
                        other, "--robot-id", ROBOT, "--json", out)
    assert code == 2 and "another application" in err and not out.exists()
    code, _, err = _cli(capsys, "history", other, "--robot-id", ROBOT)
    assert code == 2 and "another application" in err
    assert _sha(other) == before and sorted(os.listdir(tmp_path)) == ["other.sqlite"]
    with contextlib.closing(sqlite3.connect(f"file:{other}?mode=ro", uri=True)) as conn:
        assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "delete"
    empty = tmp_path / "empty.sqlite"
    empty.touch()  # an empty file is a new history
    with History(empty) as h:
        assert h.record(Record(robot_id=ROBOT, kind="evaluation", model_yaml="name: r\n", summary={})) == 1


def test_a_full_disk_is_reported_as_such_and_loses_nothing(hist):
    ids = _rows(hist)
    big = Record(robot_id=ROBOT, kind="evaluation", model_yaml="name: r\n" + "#" * 200_000, summary={})
    with History(hist) as h:
        pages = h._conn.execute("PRAGMA page_count").fetchone()[0]
        h._conn.execute(f"PRAGMA max_page_count = {pages}")  # SQLite's own "disk full" (SQLITE_FULL)
        with pytest.raises(DataError, match="the disk holding the history .* is full: nothing was recorded"):
            h.record(big)
    assert _rows(hist) == ids
    with History(hist) as h:  # still sound, still writable
        assert h.record(Record(robot_id=ROBOT, kind="evaluation", model_yaml="name: r\n", summary={})) == 3


def test_a_full_file_system_through_the_cli(made, tmp_path, capsys):
    folder = tmp_path / "full"
    folder.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(folder)],
                                           capture_output=True, timeout=MOUNT_TIMEOUT_S).returncode:
        pytest.skip("a small tmpfs needs root and mount")
    try:
        hist = folder / "h.sqlite"
        shutil.copy(made / "h.sqlite", hist)
        with contextlib.suppress(OSError), open(folder / "fill", "wb") as f:  # until the disk is full
            while True:
                f.write(b"\0" * 4096)
                f.flush()
        before = _sha(hist)
        code, _, err = _cli(capsys, "--quiet", "evaluate", made / "cal.yaml", made / "check.csv",
                            "--fit-frame", "--history", hist, "--robot-id", ROBOT)
        assert code == 2 and "is full" in err and "busy" not in err, err
        assert _sha(hist) == before and _rows(hist) == [1, 2]
    finally:  # detached even when a connection still holds it (a later run's cleanup then succeeds)
        if subprocess.run(["umount", str(folder)], capture_output=True, timeout=MOUNT_TIMEOUT_S).returncode:
            subprocess.run(["umount", "-l", str(folder)], capture_output=True, timeout=MOUNT_TIMEOUT_S)


def test_reading_creates_nothing_and_writing_leaves_the_rollback_journal(made, tmp_path):
    hist = tmp_path / "h.sqlite"
    shutil.copy(made / "h.sqlite", hist)
    with contextlib.closing(sqlite3.connect(hist)) as conn:
        conn.execute("PRAGMA journal_mode=WAL")  # as an earlier robocal left its histories
    listing = sorted(os.listdir(tmp_path))
    with History(hist) as h:
        h.record(Record(robot_id=ROBOT, kind="evaluation", model_yaml="name: r\n", summary={}))
    assert sorted(os.listdir(tmp_path)) == listing
    before = _sha(hist)
    with History(hist, readonly=True) as h:
        assert len(h.entries(ROBOT)) == 3
    assert sorted(os.listdir(tmp_path)) == listing and _sha(hist) == before
    with pytest.raises(DataError, match="does not exist"):
        History(tmp_path / "none.sqlite", readonly=True)
    assert not (tmp_path / "none.sqlite").exists()


def test_postgres_records_are_validated_on_read(postgres_url):  # noqa: F811
    psycopg = pytest.importorskip("psycopg")
    robot = f"pg-{uuid.uuid4().hex[:8]}"
    with History(postgres_url) as h:
        good = h.record(Record(robot_id=robot, kind="evaluation", model_yaml="name: r\n",
                               summary={"rms": 0.1}))
        bad = h.record(Record(robot_id=robot, kind="check", model_yaml="name: r\n",
                              summary={"verdict": "holds", "p_value": 0.5}))
    with psycopg.connect(postgres_url, autocommit=True) as conn:
        conn.execute("UPDATE records SET summary = %s WHERE id = %s",
                     ('{"verdict": "holds", "p_value": "0.5"}', bad))
    with History(postgres_url, readonly=True) as h:
        with pytest.raises(DataError, match=f"record #{bad}: its summary.p_value: expected a number"):
            h.entries(robot)
        skipped: list[str] = []
        assert [r.id for r in h.entries(robot, skipped=skipped)] == [good] and len(skipped) == 1
        with pytest.raises(DataError, match="opened read-only"):
            h.record(Record(robot_id=robot, kind="evaluation", model_yaml="name: r\n", summary={}))
        with pytest.raises(psycopg.errors.ReadOnlySqlTransaction):  # the session itself refuses writes
            h._conn.execute("DELETE FROM records WHERE id = %s", (good,))
    timeline = read_timeline(postgres_url, robot)
    assert [e["id"] for e in timeline.entries] == [good] and f"#{bad}" in timeline.warnings[0]
    with psycopg.connect(postgres_url, autocommit=True) as conn:
        conn.execute("UPDATE records SET summary = %s WHERE id = %s", ("{not json", good))
    with pytest.raises(DataError, match="no readable record .*its summary is not JSON"):
        read_timeline(postgres_url, robot)
