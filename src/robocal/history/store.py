"""The history of a robot: what was calibrated and checked when, in a database.

One table of records (a calibration or a check of one robot id) with a summary and fingerprints,
never the only copy of a result: the commands still write their outputs as files. A location is a
SQLite file (the default, through the standard library) or a ``postgresql://`` URL (a server
several engineers share, through psycopg 3: ``pip install robocal[history-pg]``).

Several writers at once all succeed: SQLite runs in WAL mode with a busy timeout, and every write
is one short ``BEGIN IMMEDIATE`` transaction retried with backoff while another writer holds the
lock; PostgreSQL serialises the schema set-up with an advisory lock. The schema carries a version
(table ``schema_version``); `MIGRATIONS` brings any older database up to date on open.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import random
import sqlite3
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from robocal.core.errors import DataError
from robocal.core.version import __version__

KINDS = ("calibration", "check", "evaluation")  # evaluation: a model judged on held-out data
POSTGRES_SCHEMES = ("postgresql://", "postgres://")
BUSY_TIMEOUT_S = 30.0  # SQLite waits this long for another writer's lock before retrying
RETRY_DEADLINE_S = 120.0  # give up (one clear error) after retrying a locked database this long
MAX_ROBOT_ID = 200  # characters of a robot id
_ADVISORY_LOCK = 7_032_032  # PostgreSQL advisory lock key of robocal's schema set-up

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
        return sha256_text(self.model_yaml)

    def timeline_entry(self) -> dict:
        """This record as one entry of ``robocal history --json`` (docs/reference/history-json.md):
        ``held_out_rms`` (mm) of a calibration with validation or of an evaluation, else null;
        ``verdict`` and ``p_value`` of a check, else null; ``rms`` the record's own figure (mm)."""
        s = self.summary
        held_out = s.get("held_out_rms") if self.kind == "calibration" else \
            s.get("rms") if self.kind == "evaluation" else None
        rms = s.get("rms_mm") if self.kind == "check" else (s.get("after") or {}).get("rms") \
            if self.kind == "calibration" else s.get("rms")
        return {"id": self.id, "kind": self.kind, "date": self.date, "held_out_rms": held_out, "rms": rms,
                "verdict": s.get("verdict"), "p_value": s.get("p_value"),
                "changed_parameters": s.get("changed_parameters") if self.kind == "check" else None,
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
    `close`. Opening creates the schema, or migrates an older one.

    Parameters
    ----------
    location : str or path
        A SQLite file (created if missing; its folder must exist) or a ``postgresql://`` URL
        (needs the ``history-pg`` extra).

    Raises
    ------
    DataError
        A folder given for a file, a missing folder, a file that is not a robocal history, a
        database newer than this robocal, or a PostgreSQL URL without psycopg.

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
    >>> with History(path) as history:  # reopened: the record is kept
    ...     [(e.id, e.kind, e.summary) for e in history.entries("cell-3")]
    [(1, 'evaluation', {'rms': 0.42})]
    """

    def __init__(self, location) -> None:
        self.location = str(location)
        self.postgres = is_postgres(self.location)
        self._conn = self._connect_postgres() if self.postgres else self._connect_sqlite()
        try:
            self._migrate()
        except BaseException:
            self._conn.close()
            raise

    # -- connections -------------------------------------------------------------------------
    def _connect_sqlite(self):
        path = Path(self.location)
        if path.is_dir():
            raise DataError(f"the history {path} is a folder: give a file name (e.g. history.sqlite)")
        if not path.parent.is_dir():
            raise DataError(f"the history's folder {path.parent} does not exist")
        conn = sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        try:
            self._retry(lambda: conn.execute("PRAGMA journal_mode=WAL"))
            conn.execute(f"PRAGMA busy_timeout={int(BUSY_TIMEOUT_S * 1000)}")
            conn.execute("PRAGMA foreign_keys=ON")
        except sqlite3.DatabaseError as exc:
            conn.close()
            raise DataError(f"{path} is not a robocal history (SQLite: {exc})") from None
        return conn

    def _connect_postgres(self):
        try:
            import psycopg
        except ImportError:
            raise DataError("a postgresql:// history needs psycopg 3: pip install 'robocal[history-pg]'") \
                from None
        try:
            return psycopg.connect(self.location, autocommit=True, connect_timeout=10)
        except psycopg.Error as exc:
            raise DataError(f"cannot connect to the history server: {' '.join(str(exc).split())}") from None

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> History:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- transactions ------------------------------------------------------------------------
    @staticmethod
    def _retry(action):
        """Run ``action`` again while SQLite reports a lock held by another writer."""
        deadline, wait = time.monotonic() + RETRY_DEADLINE_S, 0.01
        while True:
            try:
                return action()
            except sqlite3.OperationalError as exc:
                text = str(exc).lower()
                if ("locked" not in text and "busy" not in text) or time.monotonic() > deadline:
                    raise DataError(f"the history database stayed busy: {exc}") from None
                time.sleep(wait * (1 + random.random()))
                wait = min(wait * 2, 0.5)

    @contextmanager
    def _transaction(self) -> Iterator:
        """One write transaction; yields a function ``run(sql, params) -> cursor`` (``?`` marks)."""
        if self.postgres:
            with self._conn.transaction(), self._conn.cursor() as cur:
                cur.execute("SELECT pg_advisory_xact_lock(%s)", (_ADVISORY_LOCK,))
                yield lambda sql, params=(): cur.execute(sql.replace("?", "%s"), params)
            return
        conn = self._conn
        self._retry(lambda: conn.execute("BEGIN IMMEDIATE"))
        try:
            yield lambda sql, params=(): conn.execute(sql, params)
        except BaseException:
            conn.execute("ROLLBACK")
            raise
        self._retry(lambda: conn.execute("COMMIT"))

    def _query(self, sql: str, params=()) -> list[tuple]:
        if self.postgres:
            with self._conn.cursor() as cur:
                cur.execute(sql.replace("?", "%s"), params)
                return cur.fetchall()
        return self._retry(lambda: self._conn.execute(sql, params).fetchall())

    def _migrate(self) -> None:
        key = "BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY" if self.postgres \
            else "INTEGER PRIMARY KEY AUTOINCREMENT"
        try:
            with self._transaction() as run:
                run("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)")
                rows = run("SELECT version FROM schema_version").fetchall()
                version = rows[0][0] if rows else 0
                if version > SCHEMA_VERSION:
                    raise DataError(f"the history {self.location} has schema version {version}, newer than "
                                    f"this robocal's {SCHEMA_VERSION}: upgrade robocal")
                for step in MIGRATIONS[version:]:
                    for sql in step:
                        run(sql.replace("{id}", key))
                if not rows:
                    run("INSERT INTO schema_version (version) VALUES (?)", (SCHEMA_VERSION,))
                elif version < SCHEMA_VERSION:
                    run("UPDATE schema_version SET version = ?", (SCHEMA_VERSION,))
        except sqlite3.DatabaseError as exc:
            raise DataError(f"{self.location} is not a robocal history (SQLite: {exc})") from None

    @property
    def schema_version(self) -> int:
        return int(self._query("SELECT version FROM schema_version")[0][0])

    # -- records -----------------------------------------------------------------------------
    def record(self, entry: Record) -> int:
        """Store ``entry`` (its ``id`` is set) and return its id."""
        check_robot_id(entry.robot_id)
        if entry.kind not in KINDS:
            raise DataError(f"a history record is one of {KINDS}, not {entry.kind!r}")
        values = (entry.robot_id.strip(), entry.kind, entry.date, entry.robocal_version, entry.model_yaml,
                  entry.model_sha256, json.dumps(entry.summary, allow_nan=False),
                  json.dumps(entry.parameters, allow_nan=False),
                  None if entry.uncertainty is None else json.dumps(entry.uncertainty, allow_nan=False),
                  json.dumps(entry.data), entry.parent)
        with self._transaction() as run:
            cur = run("INSERT INTO records (robot_id, kind, recorded_at, robocal_version, model_yaml, "
                      "model_sha256, summary, parameters, uncertainty, data, parent_id) "
                      "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id", values)
            entry.id = int(cur.fetchone()[0])
        return entry.id

    def entries(self, robot_id: str, kind: str | None = None) -> list[Record]:
        """The records of ``robot_id`` (of one ``kind``, or all) in recording order."""
        sql = ("SELECT id, robot_id, kind, recorded_at, robocal_version, model_yaml, summary, parameters, "
               "uncertainty, data, parent_id FROM records WHERE robot_id = ?")
        params: tuple = (check_robot_id(robot_id),)
        if kind is not None:
            sql, params = sql + " AND kind = ?", (*params, kind)
        return [_record(row) for row in self._query(sql + " ORDER BY id", params)]

    def calibration(self, robot_id: str, model_yaml: str | None = None) -> Record:
        """The latest calibration of ``robot_id`` (whose model is ``model_yaml`` when given);
        DataError naming the robot id when there is none."""
        found = self.entries(robot_id, "calibration")
        if not found:
            raise DataError(f"the history {shown(self.location)} has no calibration of robot id "
                            f"{robot_id!r}: record one with robocal calibrate ... --history ... "
                            "--robot-id ...")
        if model_yaml is not None:
            digest = sha256_text(model_yaml)
            latest = found[-1]
            found = [r for r in found if r.model_sha256 == digest]
            if not found:
                raise DataError(f"none of the calibrations of robot id {robot_id!r} in the history has this "
                                f"model (the latest is #{latest.id} of {latest.date}): give the calibrated "
                                "model that calibration wrote")
        return found[-1]


def shown(location: str) -> str:
    """A location without a password (a URL's ``user:password@`` part)."""
    if is_postgres(location) and "@" in location:
        scheme, rest = location.split("://", 1)
        return f"{scheme}://{rest.rsplit('@', 1)[1]}"
    return location


def _record(row: tuple) -> Record:
    (id_, robot_id, kind, date, version, model_yaml, summary, parameters, uncertainty, data, parent) = row
    return Record(robot_id=robot_id, kind=kind, model_yaml=model_yaml, summary=json.loads(summary),
                  parameters=json.loads(parameters),
                  uncertainty=None if uncertainty is None else json.loads(uncertainty),
                  data=json.loads(data), parent=parent, date=date, robocal_version=version, id=int(id_))
