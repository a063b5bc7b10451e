"""The history store: records round-trip on SQLite and PostgreSQL, the schema carries its version and
migrates, several writers at once all succeed, bad ids and locations are refused in one line."""

from __future__ import annotations

import multiprocessing
import os
import sqlite3
import uuid

import pytest

from robocal.core.errors import DataError
from robocal.history.store import SCHEMA_VERSION, History, Record, file_sha256, now_utc

POSTGRES_ENV = "ROBOCAL_TEST_POSTGRES_URL"


@pytest.fixture(scope="module")
def postgres_url():
    """A fresh database on the server of $ROBOCAL_TEST_POSTGRES_URL (.ci/run starts one), dropped after."""
    url = os.environ.get(POSTGRES_ENV)
    if not url:
        pytest.skip(f"no PostgreSQL server for the tests: set {POSTGRES_ENV} (.ci/run starts one where "
                    "it can install PostgreSQL)")
    psycopg = pytest.importorskip("psycopg", reason="psycopg 3 is not installed (pip install "
                                                    "'.[history-pg]')")
    name = f"robocal_test_{uuid.uuid4().hex[:12]}"
    with psycopg.connect(url, autocommit=True) as conn:
        conn.execute(f"CREATE DATABASE {name}")
    base, _, _ = url.rpartition("/")
    yield f"{base}/{name}"
    with psycopg.connect(url, autocommit=True) as conn:
        conn.execute(f"DROP DATABASE {name} WITH (FORCE)")


@pytest.fixture(params=["sqlite", "postgresql"])
def location(request, tmp_path):
    if request.param == "sqlite":
        return str(tmp_path / "history.sqlite")
    return request.getfixturevalue("postgres_url")


def _entry(robot_id: str, kind: str = "calibration", **kw) -> Record:
    return Record(robot_id=robot_id, kind=kind, model_yaml=kw.pop("model_yaml", "name: r\n"),
                  summary=kw.pop("summary", {"held_out_rms": 0.05}), **kw)


def test_records_round_trip_in_recording_order(location):
    robot = f"cell-{uuid.uuid4().hex[:6]}"
    with History(location) as h:
        assert h.schema_version == SCHEMA_VERSION
        first = h.record(_entry(robot,
                                parameters=[{"name": "a2", "unit": "mm", "estimate": 705.1, "sigma": 0.01}],
                                uncertainty={"names": ["a2"], "covariance": [[1e-10]], "noise_m": 2e-5,
                                             "dof": 300},
                                data=[{"file": "d.csv", "role": "calibration", "sha256": "ab" * 32}]))
        second = h.record(_entry(robot, "check", summary={"verdict": "holds", "p_value": 0.4}, parent=first))
        h.record(_entry(robot + "-other"))
    with History(location) as h:  # reopened: nothing migrated twice, everything kept
        got = h.entries(robot)
        assert [r.id for r in got] == [first, second] and [r.kind for r in got] == ["calibration", "check"]
        assert got[0].parameters[0]["sigma"] == 0.01 and got[0].uncertainty["dof"] == 300
        assert got[0].data[0]["sha256"] == "ab" * 32 and got[1].parent == first
        assert got[1].summary == {"verdict": "holds", "p_value": 0.4} and got[1].uncertainty is None
        assert got[0].date.endswith("+00:00") and got[0].robocal_version
        assert h.calibration(robot).id == first
        assert h.calibration(robot, "name: r\n").id == first
        with pytest.raises(DataError, match="none of the calibrations of robot id"):
            h.calibration(robot, "name: other\n")
        with pytest.raises(DataError, match="no calibration of robot id 'nobody'"):
            h.calibration("nobody")


def test_ids_kinds_and_locations_are_checked(tmp_path):
    with History(tmp_path / "h.sqlite") as h:
        for bad in ("", "   ", "x" * 201, "a\nb"):
            with pytest.raises(DataError, match="robot id"):
                h.record(_entry(bad))
        with pytest.raises(DataError, match="one of"):
            h.record(_entry("r", "guess"))
    with pytest.raises(DataError, match="is a folder"):
        History(tmp_path)
    with pytest.raises(DataError, match="does not exist"):
        History(tmp_path / "missing" / "h.sqlite")
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(b"not a database at all" * 100)
    with pytest.raises(DataError, match="not a robocal history"):
        History(junk)
    assert junk.read_bytes() == b"not a database at all" * 100  # never touched


def test_an_older_schema_is_migrated_and_a_newer_one_refused(tmp_path):
    path = tmp_path / "old.sqlite"
    with sqlite3.connect(path) as conn:  # a database made before any table existed: version 0
        conn.execute("CREATE TABLE schema_version (version INTEGER NOT NULL)")
        conn.execute("INSERT INTO schema_version VALUES (0)")
    with History(path) as h:
        assert h.schema_version == SCHEMA_VERSION
        h.record(_entry("r"))
        assert len(h.entries("r")) == 1
    with sqlite3.connect(path) as conn:
        conn.execute("UPDATE schema_version SET version = ?", (SCHEMA_VERSION + 1,))
    with pytest.raises(DataError, match="newer than this robocal"):
        History(path)


def _writer(location: str, start, index: int, count: int) -> None:
    start.wait(60)  # the parent sets it at once; the parent joins each writer for 60 s
    with History(location) as h:
        for k in range(count):
            h.record(_entry("shared", summary={"writer": index, "k": k}))


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_four_writers_started_together_are_all_recorded(backend, tmp_path, request):
    location = str(tmp_path / "h.sqlite") if backend == "sqlite" else request.getfixturevalue("postgres_url")
    ctx = multiprocessing.get_context("fork")
    start = ctx.Event()
    procs = [ctx.Process(target=_writer, args=(location, start, i, 5)) for i in range(4)]
    for p in procs:
        p.start()
    start.set()
    for p in procs:
        p.join(60)
    stuck = [p for p in procs if p.is_alive()]
    for p in stuck:
        p.kill()
    assert not stuck, f"{len(stuck)} writer(s) still running after 60 s: killed"
    assert [p.exitcode for p in procs] == [0, 0, 0, 0]
    with History(location) as h:
        got = h.entries("shared")
    written = sorted((r.summary["writer"], r.summary["k"]) for r in got)
    assert written == [(i, k) for i in range(4) for k in range(5)]


def test_fingerprints_and_dates(tmp_path):
    f = tmp_path / "d.csv"
    f.write_bytes(b"abc")
    assert file_sha256(f) == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    with pytest.raises(DataError, match="cannot read"):
        file_sha256(tmp_path / "none.csv")
    assert now_utc().endswith("+00:00") and "T" in now_utc()


def test_the_timeline_marks_an_offsets_only_recalibration_and_plots_it():
    """The offsets-only entry (no held-out data) is named in the text with the record it started
    from, and drawn in the history plot (its fit RMS) rather than left out."""
    from robocal.history.timeline import Timeline

    base = {"date": "2026-01-02T03:04:05.000+00:00", "verdict": None, "p_value": None, "data": [],
            "changed_parameters": None, "parent": None}
    entries = [{**base, "id": 1, "kind": "calibration", "held_out_rms": 0.036, "rms": 0.028},
               {**base, "id": 2, "kind": "calibration", "held_out_rms": None, "rms": 0.0305,
                "parent": 1, "offsets_only": True, "date": "2026-01-03T03:04:05.000+00:00"}]
    lines = Timeline("R-1", entries).summary().splitlines()
    assert lines[1].endswith("joint zeros only (from #1)") and "joint zeros" not in lines[0]
    pytest.importorskip("matplotlib")
    from robocal.report.timeline import render_history

    page = render_history({"robot_id": "R-1", "entries": entries}, "0")
    assert "fit RMS (no held-out data)" in page and "(offsets only)" in page
