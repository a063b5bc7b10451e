"""The history of a robot: what was calibrated and checked when, in a database.

One table of records (a calibration or a check of one robot id) with a summary and fingerprints,
never the only copy of a result: the commands still write their outputs as files. A location is a
SQLite file (the default, through the standard library) or a ``postgresql://`` URL (a server
several engineers share, through psycopg 3: ``pip install robocal[history-pg]``).

Several writers at once all succeed: SQLite waits on a busy timeout, and every write is one short
``BEGIN IMMEDIATE`` transaction retried with backoff while another writer holds the lock. The
journal is SQLite's default rollback journal, not WAL: a reader then needs no shared-memory or WAL
file beside the history, so reading creates nothing and works in a read-only folder (a history in
WAL mode, written by an earlier robocal, is switched back when next written). PostgreSQL
serialises the schema set-up with an advisory lock. The schema carries a version (table
``schema_version``); `MIGRATIONS` brings any older database up to date when it is opened for
writing.

A history is never trusted: a command that only reads opens it read-only (``mode=ro``: nothing is
created, migrated or switched to WAL), a command that records first checks that the file is
writable, that it is a robocal history (a SQLite file of another application is refused without
being touched) and that SQLite's ``integrity_check`` passes, so a damaged history is never written
to. Every record read is validated (column types, JSON, the figures a command uses, its model
against its fingerprint); a lookup that finds nothing runs the integrity check before saying so (a
scrambled index hides records that are there). Each failure is one `DataError` naming its cause: a
damaged file, a bad record (by id), a full disk, a read-only file or folder, a busy database.
"""

from __future__ import annotations

import datetime
import errno
import hashlib
import json
import math
import os
import random
import sqlite3
import time
import urllib.parse
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.core.schema import Num, Obj, Seq, Str, validate
from robocal.core.version import __version__

KINDS = ("calibration", "check", "evaluation")  # evaluation: a model judged on held-out data
POSTGRES_SCHEMES = ("postgresql://", "postgres://")
BUSY_TIMEOUT_S = 30.0  # SQLite waits this long for another writer's lock before retrying
RETRY_DEADLINE_S = 120.0  # give up (one clear error) after retrying a locked database this long
MAX_ROBOT_ID = 200  # characters of a robot id
_ADVISORY_LOCK = 7_032_032  # PostgreSQL advisory lock key of robocal's schema set-up
INTEGRITY_LINES = 5  # problems integrity_check lists at most (the first is named in the error)
FULL_DISK_BYTES = 1 << 20  # free space below which an I/O error while writing is a full disk
# a calibration's stored uncertainty: a variance beyond (1 m)^2 or (1 rad)^2, an asymmetry or negative
# eigenvalue beyond this fraction of the largest entry, a noise outside 1 nm .. 1 m, more than 1e9
# degrees of freedom: not one robocal recorded (each made check exit 3)
MAX_VARIANCE = 1.0
COVARIANCE_REL_TOL = 1e-9
MIN_NOISE_M, MAX_NOISE_M = 1e-9, 1.0
MAX_DOF = 10**9
PROBE_BYTES = 1 << 16  # a probe row larger than a record's model YAML: it takes pages as a record does
FIRST_YEAR, LAST_YEAR = 1970, 9000  # a record's date outside these years was not written by robocal
MAX_RECORD_ID = 2**63 - 1  # SQLite's largest row id: a counter there cannot give the next record one
ROBOCAL_TABLES = ("schema_version", "records")  # a file with tables but not these is not a history

# Each migration brings the schema from version i to i + 1 (index i); "{id}" is the dialect's
# auto-increment primary key. Append, never edit: a released database has run the earlier ones.
MIGRATIONS: tuple[tuple[str, ...], ...] = (
    ("""CREATE TABLE records (
            id {id},
            robot_id TEXT NOT NULL,
            kind TEXT NOT NULL CHECK (kind IN ('calibration', 'check', 'evaluation')),
            recorded_at TEXT NOT NULL,
            robocal_version TEXT NOT NULL,
            model_yaml TEXT NOT NULL,
            model_sha256 TEXT NOT NULL,
            summary TEXT NOT NULL,
            parameters TEXT NOT NULL,
            uncertainty TEXT,
            data TEXT NOT NULL,
            parent_id INTEGER REFERENCES records (id))""",
     "CREATE INDEX records_robot ON records (robot_id, id)"),
)
SCHEMA_VERSION = len(MIGRATIONS)


@dataclass
class Record:
    """One entry of a robot's history.

    ``summary``: the result's figures (mm; a check's verdict and p-value); ``parameters``: rows
    ``{name, unit, estimate, sigma}`` (mm, deg); ``uncertainty``: what a later check needs of a
    calibration (its covariance in SI, the noise estimate), None for a check; ``data``: the input
    files ``{file, role, sha256}``; ``parent``: the record a derived calibration (offsets only) or a
    check started from; ``date``: UTC, ISO 8601 with the offset. ``id`` is set once recorded.

    Parameters
    ----------
    robot_id : str
        The robot's id: printable text of 1 to ``MAX_ROBOT_ID`` characters.
    kind : str
        "calibration", "check" or "evaluation".
    model_yaml : str
        The model the record is about, as model YAML text (docs/model-yaml.md).
    summary : dict
        The figures (mm); of a check, its verdict and p-value.
    parameters : list of dict
        Rows ``{name, unit, estimate, sigma}`` (mm, deg).
    uncertainty : dict or None
        What a later check needs of a calibration (its covariance in SI, the noise); None for a check.
    data : list of dict
        The input files ``{file, role, sha256}``.
    parent : int or None
        The record a derived calibration (offsets only) or a check started from.
    date : str
        UTC, ISO 8601 with the offset; default now.
    robocal_version : str
        The version that made the record.
    id : int or None
        Set once recorded.

    See Also
    --------
    robocal.history.History : The store of records.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.history.store import Record
    >>> from robocal.kinematics.model_file import dump_model
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> entry = Record(robot_id="cell-3", kind="evaluation", model_yaml=dump_model(robot),
    ...                summary={"rms": 0.42})  # mm, on held-out data
    >>> entry.id is None, len(entry.model_sha256)  # not recorded yet; SHA-256 of the model
    (True, 64)
    >>> row = entry.timeline_entry()  # as in robocal history --json
    >>> row["kind"], row["held_out_rms"], row["verdict"]
    ('evaluation', 0.42, None)
    """

    robot_id: str
    kind: str
    model_yaml: str
    summary: dict
    parameters: list = field(default_factory=list)
    uncertainty: dict | None = None
    data: list = field(default_factory=list)
    parent: int | None = None
    date: str = field(default_factory=lambda: now_utc())
    robocal_version: str = __version__
    id: int | None = None

    @property
    def model_sha256(self) -> str:
        """SHA-256 (hex) of ``model_yaml``: which model the record is about."""
        return sha256_text(self.model_yaml)

    def timeline_entry(self) -> dict:
        """This record as one entry of ``robocal history --json`` (docs/reference/history-json.md):
        ``held_out_rms`` (mm) of a calibration with validation or of an evaluation, else null;
        ``verdict`` and ``p_value`` of a check, else null; ``rms`` the record's own figure (mm).

        Returns
        -------
        dict
            The timeline entry (JSON-ready).
        """
        s = self.summary
        held_out = s.get("held_out_rms") if self.kind == "calibration" else \
            s.get("rms") if self.kind == "evaluation" else None
        rms = s.get("rms_mm") if self.kind == "check" else (s.get("after") or {}).get("rms") \
            if self.kind == "calibration" else s.get("rms")
        return {"id": self.id, "kind": self.kind, "date": self.date, "held_out_rms": held_out, "rms": rms,
                "verdict": s.get("verdict"), "p_value": s.get("p_value"),
                "changed_parameters": s.get("changed_parameters") if self.kind == "check" else None,
                **({"frame_change": s["frame_change"]} if self.kind == "check" and s.get("frame_change")
                   else {}),
                "parent": self.parent, "model_sha256": self.model_sha256, "data": self.data,
                "robocal_version": self.robocal_version,
                **({"offsets_only": True} if s.get("offsets_only") else {})}


def now_utc() -> str:
    """The current time, UTC, ISO 8601 with its offset (``2026-01-02T03:04:05.678+00:00``)."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="milliseconds")


def sha256_text(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def file_sha256(path) -> str:
    """SHA-256 (hex) of a file's bytes; DataError when it cannot be read."""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                digest.update(block)
    except OSError as exc:
        raise DataError(f"cannot read {path} to fingerprint it: {exc.strerror or exc}") from None
    return digest.hexdigest()


def check_robot_id(robot_id: str) -> str:
    """A robot id: printable text of 1 to `MAX_ROBOT_ID` characters (DataError otherwise)."""
    if not isinstance(robot_id, str) or not robot_id.strip() or len(robot_id) > MAX_ROBOT_ID \
            or not robot_id.isprintable():
        raise DataError(f"a robot id is printable text of 1 to {MAX_ROBOT_ID} characters, got "
                        f"{robot_id!r:.60}")
    return robot_id.strip()


def is_postgres(location: str) -> bool:
    return str(location).startswith(POSTGRES_SCHEMES)


class History:
    """A history database (SQLite file or PostgreSQL URL); use as a context manager or call
    `close`. Opening for writing creates the schema, or migrates an older one; opening read-only
    (``readonly=True``) changes nothing, not even the journal mode.

    Parameters
    ----------
    location : str or path
        A SQLite file (created if missing when writing; its folder must exist) or a
        ``postgresql://`` URL (needs the ``history-pg`` extra).
    readonly : bool
        Only read: the SQLite file is opened with ``mode=ro`` (in a read-only folder as immutable)
        and must exist; a PostgreSQL session is read-only.

    Raises
    ------
    DataError
        A folder given for a file, a missing folder, a file that is not a robocal history (left
        untouched), a damaged one (SQLite's integrity check), a read-only file or folder when
        writing, a schema version that is not a whole number or newer than this robocal, or a
        PostgreSQL URL without psycopg.

    See Also
    --------
    robocal.history.Record : One entry.
    robocal.history.check.check_calibration : Check a recorded calibration.
    robocal.history.offsets.recalibrate_offsets : Recalibrate the joint offsets only.

    Examples
    --------
    >>> import os, tempfile
    >>> import robocal as rc
    >>> from robocal.history.store import History, Record
    >>> from robocal.kinematics.model_file import dump_model
    >>> path = os.path.join(tempfile.mkdtemp(), "history.sqlite")
    >>> yaml_text = dump_model(rc.Robot.from_catalog("abb_irb2600"))
    >>> with History(path) as history:
    ...     history.record(Record(robot_id="cell-3", kind="evaluation", model_yaml=yaml_text,
    ...                           summary={"rms": 0.42}))
    1
    >>> with History(path, readonly=True) as history:  # reopened: the record is kept
    ...     [(e.id, e.kind, e.summary) for e in history.entries("cell-3")]
    [(1, 'evaluation', {'rms': 0.42})]
    """

    def __init__(self, location, readonly: bool = False) -> None:
        self.location = str(location)
        self.readonly = readonly
        self._conn = None  # set once connected (an error before then is worded without it)
        self.postgres = is_postgres(self.location)
        self._conn = self._connect_postgres() if self.postgres else self._connect_sqlite()
        try:
            if readonly:
                self._check_schema()
            else:
                self._migrate()  # the file was checked sound before (and is again before each insert)
        except BaseException:
            self._conn.close()
            raise

    # -- connections -------------------------------------------------------------------------
    def _connect_sqlite(self):
        path = Path(self.location)
        if path.is_dir():
            raise DataError(f"the history {path} is a folder: give a file name (e.g. history.sqlite)")
        if path.exists() and not path.is_file():  # a FIFO was 'does not exist' or exit 3 (disk I/O error)
            raise DataError(f"the history {path} is not a regular file (a device, a pipe or a socket): give "
                            "a SQLite file (e.g. history.sqlite)")
        if not path.parent.is_dir():
            raise DataError(f"the history's folder {path.parent} does not exist")
        if self.readonly and not path.is_file():
            raise DataError(f"the history {path} does not exist")
        if self.readonly:
            conn = _open_readonly(path, self._failure)
            try:
                self._identify(conn)
                conn.execute(f"PRAGMA busy_timeout={int(BUSY_TIMEOUT_S * 1000)}")
                conn.execute("PRAGMA query_only=ON")
            except BaseException:
                conn.close()
                raise
            return conn
        if path.is_file() and path.stat().st_size:
            with _closing(_open_readonly(path, self._failure)) as conn:  # what it is, before any write
                self._identify(conn)
                self._check_sound(conn)  # a damaged file is not touched, not even its journal mode
                self._check_insertable(conn)  # refused now, not after the command wrote its outputs
        _check_writable(path)
        conn = sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        conn.execute(f"PRAGMA busy_timeout={int(BUSY_TIMEOUT_S * 1000)}")
        conn.execute("PRAGMA foreign_keys=ON")
        return conn

    def _identify(self, conn) -> None:
        """Refuse (DataError) a SQLite file that is not a robocal history: not SQLite, damaged
        beyond reading its table list, or holding tables but not robocal's."""
        try:
            tables = {row[0] for row in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        except sqlite3.DatabaseError as exc:
            raise self._failure(exc, "reading") from None
        if tables and "schema_version" not in tables:
            raise DataError(f"{self.location} is not a robocal history: it is a SQLite database of another "
                            f"application (tables {', '.join(sorted(tables))[:120]}); robocal left it "
                            "untouched")

    def _check_insertable(self, conn) -> None:
        """Refuse (DataError) a history a record cannot be added to as robocal made it: one holding
        a trigger (robocal makes none: another program's could delete or change records when
        robocal inserts, or abort the insert after the command wrote its outputs), or whose record
        id counter is at its end (SQLite's answer would be a misleading "disk is full")."""
        try:
            triggers = [r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'trigger'")]
            counted = conn.execute("SELECT count(*) FROM sqlite_master WHERE name = 'sqlite_sequence'")
            seq = conn.execute("SELECT seq FROM sqlite_sequence WHERE name = 'records'").fetchall() \
                if counted.fetchone()[0] else []
        except sqlite3.DatabaseError as exc:
            raise self._failure(exc, "reading") from None
        if triggers:
            raise DataError(f"the history {shown(self.location)} holds trigger(s) robocal never makes "
                            f"({', '.join(triggers)[:120]}): another program changed it, and a trigger can "
                            "delete or change records when one is added; robocal writes nothing in it")
        if seq and not (isinstance(seq[0][0], int) and 0 <= seq[0][0] < MAX_RECORD_ID):
            raise DataError(f"the history {shown(self.location)} has a damaged record id counter "
                            f"({seq[0][0]!r:.40} in sqlite_sequence): another program changed it; robocal "
                            "writes nothing in it")

    def _connect_postgres(self):
        try:
            import psycopg
        except ImportError:
            raise DataError("a postgresql:// history needs psycopg 3: pip install 'robocal[history-pg]'") \
                from None
        try:
            conn = psycopg.connect(self.location, autocommit=True, connect_timeout=10)
        except psycopg.Error as exc:
            raise DataError(f"cannot connect to the history server: {' '.join(str(exc).split())}") from None
        if self.readonly:
            conn.execute("SET default_transaction_read_only = on")
        return conn

    def close(self) -> None:
        """Close the connection (leaving a ``with`` block does it)."""
        self._conn.close()

    def __enter__(self) -> History:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- failures ----------------------------------------------------------------------------
    def _failure(self, exc: Exception, doing: str) -> DataError:
        """The `DataError` of a database error met while ``doing`` ("reading", "writing"), worded
        by its cause: a damaged file (with the integrity check's first finding), a full disk, a
        read-only file or folder, a file that is not a database, a busy lock."""
        name = getattr(exc, "sqlite_errorname", "") or ""
        text = " ".join(str(exc).split())
        where = shown(self.location)
        if isinstance(exc, OSError) and exc.errno == errno.ENOSPC or name.startswith("SQLITE_FULL") or \
                (name.startswith(("SQLITE_IOERR", "SQLITE_CANTOPEN")) and self._disk_nearly_full()):
            return DataError(f"the disk holding the history {where} is full: nothing was recorded; free some "
                             f"space and run the command again ({text})")
        if name.startswith("SQLITE_READONLY"):
            return DataError(f"cannot write the history {where}: it is read-only ({text})")
        if name.startswith("SQLITE_CANTOPEN"):
            return DataError(f"cannot open the history {where}: its file or folder cannot be read or, for "
                             f"writing, written ({text})")
        if name.startswith("SQLITE_NOTADB"):
            return DataError(f"{where} is not a robocal history: not a SQLite database ({text}); robocal "
                             "left it untouched")
        if name.startswith(("SQLITE_BUSY", "SQLITE_LOCKED")):
            return DataError(f"the history database {where} stayed busy for {RETRY_DEADLINE_S:.0f} s: "
                             f"another program holds its lock ({text})")
        if name.startswith("SQLITE_CORRUPT") or "malformed" in text:
            return self._damaged(self._integrity() or text)
        return DataError(f"the history {where} failed while {doing} ({name or type(exc).__name__}: {text})")

    def _damaged(self, finding: str) -> DataError:
        where = shown(self.location)
        return DataError(f"the history {where} is damaged (SQLite integrity check: {finding}); robocal reads "
                         f"and writes nothing in it: restore it from a backup (sqlite3 {where} .recover "
                         "salvages what is left into a new file)")

    def _integrity(self, conn=None) -> str | None:
        """None when SQLite's ``integrity_check`` passes on ``conn`` (default: the history's; on
        PostgreSQL always None), else its findings."""
        conn = conn or self._conn
        if self.postgres or conn is None:
            return None
        try:
            rows = conn.execute(f"PRAGMA integrity_check({INTEGRITY_LINES})").fetchall()
        except sqlite3.DatabaseError as exc:
            return " ".join(str(exc).split())
        found = [str(r[0]) for r in rows]
        return None if found == ["ok"] else "; ".join(found)

    def _check_sound(self, conn=None) -> None:
        """DataError when the integrity check (on ``conn``, default the history's) finds damage."""
        finding = self._integrity(conn)
        if finding:
            raise self._damaged(finding)

    def _disk_nearly_full(self) -> bool:
        try:
            stat = os.statvfs(Path(self.location).parent)
        except OSError:
            return False
        return stat.f_bavail * stat.f_frsize < FULL_DISK_BYTES

    # -- transactions ------------------------------------------------------------------------
    def _retry(self, action):
        """Run ``action`` again while SQLite reports a lock held by another writer; any other
        error (or a lock held past `RETRY_DEADLINE_S`) is a `DataError` worded by its cause."""
        deadline, wait = time.monotonic() + RETRY_DEADLINE_S, 0.01
        while True:
            try:
                return action()
            except (sqlite3.Error, OSError) as exc:
                text = str(exc).lower()
                busy = isinstance(exc, sqlite3.OperationalError) and ("locked" in text or "busy" in text)
                if not busy or time.monotonic() > deadline:
                    raise self._failure(exc, "reading" if self.readonly else "writing") from None
                time.sleep(wait * (1 + random.random()))
                wait = min(wait * 2, 0.5)

    @contextmanager
    def _transaction(self) -> Iterator:
        """One write transaction; yields a function ``run(sql, params) -> cursor`` (``?`` marks)."""
        if self.readonly:
            raise DataError(f"the history {shown(self.location)} was opened read-only")
        if self.postgres:
            with self._conn.transaction(), self._conn.cursor() as cur:
                cur.execute("SELECT pg_advisory_xact_lock(%s)", (_ADVISORY_LOCK,))
                yield lambda sql, params=(): cur.execute(sql.replace("?", "%s"), params)
            return
        conn = self._conn
        self._retry(lambda: conn.execute("BEGIN IMMEDIATE"))
        try:
            yield lambda sql, params=(): conn.execute(sql, params)
        except sqlite3.Error as exc:
            _rollback(conn)
            raise self._failure(exc, "writing") from None
        except BaseException:
            _rollback(conn)
            raise
        self._retry(lambda: conn.execute("COMMIT"))
        # an older robocal's WAL history is switched back once a write succeeded (before it, a
        # refused write would have changed the file)
        if str(conn.execute("PRAGMA journal_mode").fetchone()[0]).lower() == "wal":
            self._retry(lambda: conn.execute("PRAGMA journal_mode=DELETE"))

    def _query(self, sql: str, params=()) -> list[tuple]:
        if self.postgres:
            with self._conn.cursor() as cur:
                cur.execute(sql.replace("?", "%s"), params)
                return cur.fetchall()
        return self._retry(lambda: self._conn.execute(sql, params).fetchall())

    def _version(self, rows: list[tuple]) -> int:
        """The schema version of ``rows`` (of ``SELECT version FROM schema_version``): 0 when
        none, DataError when it is not one whole number or newer than this robocal."""
        if not rows:
            return 0
        version = rows[0][0]
        if len(rows) != 1 or isinstance(version, bool) or not isinstance(version, int):
            raise DataError(f"the history {shown(self.location)} has a damaged schema version "
                            f"({len(rows)} row(s), {version!r:.40} of type {type(version).__name__}, not one "
                            "whole number): it was changed by another program; robocal reads and writes "
                            "nothing in it")
        if version > SCHEMA_VERSION:
            raise DataError(f"the history {shown(self.location)} has schema version {version}, newer than "
                            f"this robocal's {SCHEMA_VERSION}: upgrade robocal")
        return version

    def _stored_version(self) -> int | None:
        """The schema version the history holds (validated, `_version`), None without the table."""
        probe = "SELECT to_regclass('schema_version') IS NOT NULL" if self.postgres else \
            "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'schema_version'"
        if not self._query(probe)[0][0]:
            return None
        return self._version(self._query("SELECT version FROM schema_version"))

    def _migrate(self) -> None:
        """Create or bring the schema up to date; an up-to-date history is not written to at all."""
        if self._stored_version() == SCHEMA_VERSION:
            return
        key = "BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY" if self.postgres \
            else "INTEGER PRIMARY KEY AUTOINCREMENT"
        with self._transaction() as run:
            run("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)")
            rows = run("SELECT version FROM schema_version").fetchall()
            version = self._version(rows)
            for step in MIGRATIONS[version:]:
                for sql in step:
                    run(sql.replace("{id}", key))
            if not rows:
                run("INSERT INTO schema_version (version) VALUES (?)", (SCHEMA_VERSION,))
            elif version < SCHEMA_VERSION:
                run("UPDATE schema_version SET version = ?", (SCHEMA_VERSION,))

    def _check_schema(self) -> None:
        """Read-only: the history holds robocal's tables at this robocal's schema version."""
        version = self._stored_version()
        if version is None:
            raise DataError(f"{shown(self.location)} is not a robocal history (it has no schema_version "
                            "table): record in it first (calibrate ... --history)")
        if version < SCHEMA_VERSION:
            raise DataError(f"the history {shown(self.location)} has schema version {version}, older than "
                            f"this robocal's {SCHEMA_VERSION}: a command that records in it (calibrate, "
                            "check or evaluate with --history) brings it up to date")

    @property
    def schema_version(self) -> int:
        """The version of the database's schema."""
        return self._version(self._query("SELECT version FROM schema_version"))

    # -- records -----------------------------------------------------------------------------
    def record(self, entry: Record) -> int:
        """Store ``entry`` (its ``id`` is set) and return its id.

        Parameters
        ----------
        entry : Record
            The record to store.

        Returns
        -------
        int
            Its id.
        """
        check_robot_id(entry.robot_id)
        if entry.kind not in KINDS:
            raise DataError(f"a history record is one of {KINDS}, not {entry.kind!r}")
        values = (entry.robot_id.strip(), entry.kind, entry.date, entry.robocal_version, entry.model_yaml,
                  entry.model_sha256, json.dumps(entry.summary, allow_nan=False),
                  json.dumps(entry.parameters, allow_nan=False),
                  None if entry.uncertainty is None else json.dumps(entry.uncertainty, allow_nan=False),
                  json.dumps(entry.data), entry.parent)
        with self._transaction() as run:
            finding = self._integrity()  # under the write lock: nothing can damage it before the insert
            if finding:
                raise self._damaged(finding)
            cur = run("INSERT INTO records (robot_id, kind, recorded_at, robocal_version, model_yaml, "
                      "model_sha256, summary, parameters, uncertainty, data, parent_id) "
                      "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id", values)
            entry.id = int(cur.fetchone()[0])
        return entry.id

    def probe_write(self) -> None:
        """Check, before a command writes its outputs, that a record can be added: a record-sized
        row is inserted and rolled back (the file's bytes stay as they were). DataError worded by
        the cause otherwise: a freelist pointer changed by a flipped byte passed the integrity
        check, and the insert after the outputs failed ('malformed': outputs left, exit 2)."""
        if self.readonly or self.postgres:
            return
        conn = self._conn
        self._retry(lambda: conn.execute("BEGIN IMMEDIATE"))
        try:
            conn.execute("INSERT INTO records (robot_id, kind, recorded_at, robocal_version, model_yaml, "
                         "model_sha256, summary, parameters, uncertainty, data, parent_id) "
                         "VALUES (?, 'check', ?, ?, ?, '', '{}', '[]', NULL, '[]', NULL)",
                         ("robocal write probe", now_utc(), __version__, "#" * PROBE_BYTES))
            # on the writing connection, as record() will: a read-only connection's check passed a
            # file whose CHECK constraint this one finds broken (the insert then refused, after the outputs)
            finding = self._integrity()
        except sqlite3.Error as exc:
            raise self._failure(exc, "writing") from None
        finally:
            _rollback(conn)
        if finding:
            raise self._damaged(finding)

    def entries(self, robot_id: str, kind: str | None = None,
                skipped: list[str] | None = None) -> list[Record]:
        """The records of ``robot_id`` (of one ``kind``, or all) in recording order, each
        validated (`validate_row`). A record that fails is refused (DataError naming it and the
        cause), or, when a list ``skipped`` is given, left out with a line appended there. On
        SQLite the rows found through the index are counted in the table itself too (a scan of the
        robot id column); when none is found or the counts differ, SQLite's integrity check runs
        and the history is reported damaged (a scrambled index hides records that are there).

        Parameters
        ----------
        robot_id : str
            The robot.
        kind : str, optional
            Only records of this kind (``calibration``, ``check``...).
        skipped : list of str, optional
            Receives one line a record left out; without it an unreadable record raises.

        Returns
        -------
        list of Record
            In recording order.

        Raises
        ------
        DataError
            An unreadable record (without ``skipped``).
        """
        sql = ("SELECT id, robot_id, kind, recorded_at, robocal_version, model_yaml, model_sha256, summary, "
               "parameters, uncertainty, data, parent_id FROM records WHERE robot_id = ?")
        params: tuple = (check_robot_id(robot_id),)
        if kind is not None:
            sql, params = sql + " AND kind = ?", (*params, kind)
        rows = self._query(sql + " ORDER BY id", params)
        if not rows or any(row[1] != params[0] or kind not in (None, row[2]) for row in rows) or \
                not self.postgres and len(rows) != self._query(
                    "SELECT count(*) FROM records NOT INDEXED WHERE robot_id = ?"
                    + (" AND kind = ?" if kind is not None else ""), params)[0][0]:
            self._check_sound()  # nothing found, rows not asked for, or rows the index did not give
            if rows:
                raise self._damaged("the index records_robot and the table disagree on robot id "
                                    f"{params[0]!r}")
        found = []
        for row in rows:
            try:
                found.append(validate_row(row, params[0], kind))
            except BadRecordError as exc:
                if skipped is None:
                    raise DataError(f"the history {shown(self.location)}: {exc}; robocal does not use a "
                                    "damaged record (restore the history from a backup)") from None
                skipped.append(f"left out {exc}")
        return found

    def find_calibration(self, robot_id: str, model_yaml: str | None = None) -> Record | None:
        """The latest calibration of ``robot_id`` (whose model is ``model_yaml`` when given), None
        when there is none; DataError when any calibration record of the robot is unreadable
        (it could be the one asked for: an older one would be a wrong answer that looks right).

        Parameters
        ----------
        robot_id : str
            The robot.
        model_yaml : str, optional
            Only a calibration of this model.

        Returns
        -------
        Record or None
            The latest calibration.

        Raises
        ------
        DataError
            A calibration record of the robot is unreadable.
        """
        found = self.entries(robot_id, "calibration")
        if model_yaml is not None:
            digest = sha256_text(model_yaml)
            found = [r for r in found if r.model_sha256 == digest]
            if not found:
                self._check_sound()
        return found[-1] if found else None

    def calibration(self, robot_id: str, model_yaml: str | None = None) -> Record:
        """The latest calibration of ``robot_id`` (whose model is ``model_yaml`` when given);
        DataError naming the robot id when there is none.

        Parameters
        ----------
        robot_id : str
            The robot.
        model_yaml : str, optional
            Only a calibration of this model.

        Returns
        -------
        Record
            The latest calibration.

        Raises
        ------
        DataError
            There is none.
        """
        found = self.find_calibration(robot_id, model_yaml)
        if found is not None:
            return found
        every = self.entries(robot_id, "calibration")
        if not every:
            raise DataError(f"the history {shown(self.location)} has no calibration of robot id "
                            f"{robot_id!r}: record one with robocal calibrate ... --history ... "
                            "--robot-id ...")
        latest = every[-1]
        raise DataError(f"none of the calibrations of robot id {robot_id!r} in the history has this "
                        f"model (the latest is #{latest.id} of {latest.date}): give the calibrated "
                        "model that calibration wrote")


def shown(location: str) -> str:
    """A location without a password (a URL's ``user:password@`` part)."""
    if is_postgres(location) and "@" in location:
        scheme, rest = location.split("://", 1)
        return f"{scheme}://{rest.rsplit('@', 1)[1]}"
    return location


def _open_readonly(path: Path, failure):
    """A read-only connection to the SQLite file ``path`` (``mode=ro``: it creates nothing). In a
    folder that cannot be written and without a WAL file, no writer can change the database (a
    writer needs that file), so it is opened as immutable (no lock or shared-memory file).
    ``failure(exc, doing)``: the DataError of any other SQLite error."""
    uri = f"file:{urllib.parse.quote(str(path.resolve()))}?mode=ro"
    conn = None
    try:
        conn = sqlite3.connect(uri, uri=True, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        conn.execute("SELECT 1 FROM sqlite_master LIMIT 1").fetchall()
        return conn
    except sqlite3.DatabaseError as exc:
        if conn is not None:
            conn.close()  # a connection left open keeps the file (and its file system) busy
        if getattr(exc, "sqlite_errorname", "").startswith("SQLITE_NOTADB"):
            raise DataError(f"{path} is not a robocal history: not a SQLite database ({exc}); robocal left "
                            "it untouched") from None
        if os.access(path.parent, os.W_OK) or Path(f"{path}-wal").exists():
            raise failure(exc, "reading") from None
    conn = sqlite3.connect(uri + "&immutable=1", uri=True, isolation_level=None)
    try:
        conn.execute("SELECT 1 FROM sqlite_master LIMIT 1").fetchall()
    except sqlite3.DatabaseError as exc:
        conn.close()
        raise failure(exc, "reading") from None
    return conn


@contextmanager
def _closing(conn) -> Iterator:
    try:
        yield conn
    finally:
        conn.close()


def _rollback(conn) -> None:
    with suppress(sqlite3.Error):  # the failed statement may have ended it (SQLite rolls back on a full disk)
        conn.execute("ROLLBACK")


def _check_writable(path: Path) -> None:
    """DataError unless the SQLite history ``path`` (and the journal files SQLite makes beside it)
    can be written: checked before a command writes any output, so it writes all or none."""
    if path.exists() and not (os.access(path, os.W_OK) and path.stat().st_mode & 0o222):
        raise DataError(f"cannot record in the history {path}: the file is read-only (make it writable, or "
                        "leave out --history); nothing was written")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise DataError(f"cannot record in the history {path}: its folder {path.parent} is not writable "
                        "(SQLite writes its journal beside the file); nothing was written")


class BadRecordError(Exception):
    """A history row that fails validation: its id and the cause, in words."""

    def __init__(self, ident, cause: str) -> None:
        super().__init__(f"record #{ident}: {cause}")


# a record's JSON as `robocal.core.schema` checks it (numbers finite or null, texts, the rows' fields)
# (a check's shifts are printed as figures: a null or missing one was exit 3 in history --report)
_ROWS = {"shift": Obj({"name": Str(), "unit": Str(), "shift": Num(), "sigma": Num()},
                      required=("name", "unit", "shift", "sigma")),
         "parameter": Obj({"name": Str(), "unit": Str(), "estimate": Num(null=True), "sigma": Num(null=True)},
                          required=("name", "unit", "estimate", "sigma")),
         "file": Obj({"file": Str(), "role": Str(), "sha256": Str()}, required=("file", "role", "sha256"))}
_FIGURES = Obj({**{name: Num(null=True) for name in ("held_out_rms", "rms", "rms_mm", "predicted_rms_mm",
                                                      "p_value", "mean", "max", "p95")},
                **{part: Obj({"rms": Num(null=True)}, null=True) for part in ("before", "after")},
                "changed_parameters": Seq(_ROWS["shift"], null=True)})
_TEXT_COLUMNS = ("robot_id", "kind", "recorded_at", "robocal_version", "model_yaml", "model_sha256",
                 "summary", "parameters", "data")


def _json(ident, column: str, text, kind: type):
    try:
        value = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise BadRecordError(ident, f"its {column} is not JSON ({exc})") from None
    if not isinstance(value, kind):
        raise BadRecordError(ident, f"its {column} is JSON {type(value).__name__}, not {kind.__name__}")
    return value


def _number(value) -> bool:
    return value is None or (isinstance(value, int | float) and not isinstance(value, bool)
                             and math.isfinite(value))


def validate_row(row: tuple, robot_id: str, kind: str | None) -> Record:
    """The `Record` of a ``records`` row (id, robot_id, kind, recorded_at, robocal_version,
    model_yaml, model_sha256, summary, parameters, uncertainty, data, parent_id), or `BadRecordError`
    naming the first fault: a column of the wrong type, text that is not JSON (or not the JSON
    kind expected), a figure that is not a finite number or null (a check's p-value in [0, 1]
    and its verdict), an uncertainty without its covariance or noise, a model that
    does not match its SHA-256, a record of another robot id or kind than asked."""
    ident, rid, rkind, date, version, model_yaml, digest, summary, parameters, uncertainty, data, parent = \
        row
    if isinstance(ident, bool) or not isinstance(ident, int):
        raise BadRecordError(ident, f"its id is {ident!r:.40}, not a whole number")
    for name, value in zip(_TEXT_COLUMNS, (rid, rkind, date, version, model_yaml, digest, summary, parameters,
                                           data), strict=True):
        if not isinstance(value, str):
            raise BadRecordError(ident, f"its {name} is {type(value).__name__} {value!r:.40}, not text")
    if rid != robot_id or rkind not in KINDS or (kind is not None and rkind != kind):
        raise BadRecordError(ident, f"the database returned it for robot id {robot_id!r} but it is a "
                                    f"{rkind!r:.40} of robot id {rid!r:.40} (a damaged index)")
    if parent is not None and (isinstance(parent, bool) or not isinstance(parent, int)):
        raise BadRecordError(ident, f"its parent_id is {parent!r:.40}, not a record id")
    try:
        year = datetime.datetime.fromisoformat(date).year
    except ValueError:
        raise BadRecordError(ident, f"its date {date!r:.40} is not an ISO 8601 time") from None
    if not FIRST_YEAR <= year <= LAST_YEAR:  # year 1 broke the timeline's plot (exit 3)
        raise BadRecordError(ident, f"its date {date!r:.40} is not one robocal could have recorded "
                                    f"(years {FIRST_YEAR} to {LAST_YEAR})")
    if sha256_text(model_yaml) != digest:
        raise BadRecordError(ident, "its model does not match its SHA-256 fingerprint (changed after "
                                    "recording)")
    figures = _json(ident, "summary", summary, dict)
    _check(ident, figures, _FIGURES, "its summary")
    if rkind == "check" and (figures.get("verdict") not in ("holds", "changed")
                             or not isinstance(figures.get("p_value"), int | float)
                             or not 0 <= figures["p_value"] <= 1):
        raise BadRecordError(ident, "a check needs a verdict (holds, changed) and a p-value in [0, 1], it "
                                    f"has {figures.get('verdict')!r:.20} and {figures.get('p_value')!r:.20}")
    unc = None if uncertainty is None else _json(ident, "uncertainty", uncertainty, dict)
    if unc is not None:
        _check_uncertainty(ident, unc)
    rows = _json(ident, "parameters", parameters, list)
    _check(ident, rows, Seq(_ROWS["parameter"]), "its parameters")
    files = _json(ident, "data", data, list)
    _check(ident, files, Seq(_ROWS["file"]), "its data")
    return Record(robot_id=rid, kind=rkind, model_yaml=model_yaml, summary=figures, parameters=rows,
                  uncertainty=unc, data=files, parent=parent, date=date, robocal_version=version, id=ident)


def _check(ident, value, spec, where: str) -> None:
    """``value`` follows ``spec`` (`robocal.core.schema`), else BadRecordError naming the field."""
    try:
        validate(value, spec, where)
    except DataError as exc:
        raise BadRecordError(ident, str(exc)) from None


def _check_uncertainty(ident, unc: dict) -> None:
    """A calibration's uncertainty: names, a square finite covariance over them, noise > 0, dof >= 1."""
    fault = uncertainty_fault(unc)
    if fault:
        raise BadRecordError(ident, f"its uncertainty's {fault}")


def uncertainty_fault(unc: dict) -> str | None:
    """What makes ``unc`` (``names``, ``covariance`` (SI), ``noise_m``, ``dof``) not the uncertainty
    a calibration makes (one phrase, starting with the field), None when it is one."""
    names = unc.get("names")
    if not (isinstance(names, list | tuple) and all(isinstance(n, str) for n in names)):
        return "names are not a list of parameter names"
    try:
        cov = np.asarray(unc.get("covariance"), dtype=float)
    except (TypeError, ValueError):
        cov = np.empty(0)
    if cov.shape != (len(names), len(names)) or not np.isfinite(cov).all():
        return f"covariance is not a finite {len(names)} x {len(names)} matrix"
    # a covariance a calibration makes: symmetric, positive semi-definite, no sigma beyond 1 m or
    # 1 rad (one that was not made check exit 3: a Cholesky factor of a matrix that has none)
    scale = float(np.abs(cov).max(initial=0.0))
    if scale > MAX_VARIANCE or np.abs(cov - cov.T).max(initial=0.0) > COVARIANCE_REL_TOL * scale or \
            (cov.size and np.linalg.eigvalsh(cov).min() < -COVARIANCE_REL_TOL * scale):
        return ("covariance is not one a calibration makes (symmetric, positive semi-definite, variances "
                f"at most {MAX_VARIANCE:g})")
    noise, dof = unc.get("noise_m"), unc.get("dof")
    if not (_number(noise) and noise is not None and MIN_NOISE_M <= noise <= MAX_NOISE_M):
        return f"noise_m is {noise!r:.40}, not a number in [{MIN_NOISE_M:g}, {MAX_NOISE_M:g}] (m)"
    if isinstance(dof, bool) or not isinstance(dof, int | np.integer) or not 1 <= dof <= MAX_DOF:
        return f"dof is {dof!r:.40}, not a whole number in [1, {MAX_DOF:g}]"
    return None
