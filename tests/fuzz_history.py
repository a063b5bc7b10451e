"""Mutation fuzzing of the history read and write paths (shared by tests/test_fuzz_history.py and
scripts/fuzz_history.py).

A seed history is made through the CLI (a calibration, a check and an evaluation of one robot id,
a calibration of another). A mutant is a copy changed by one to three operators: a column of a
random record given another type or value (NULL, text for a number, broken or hostile JSON, a
huge or non-finite figure, markup and control characters), records deleted, duplicated or
re-parented, the schema altered (a trigger, a view, an extra table, a dropped index, a rebuilt
table, a schema version changed), or the file's bytes changed (a page overwritten, bytes flipped,
the file truncated or grown). Each mutant goes through ``history``, ``check``, ``evaluate`` and
(``calibrate=True``) ``calibrate --history``. The contract (:func:`judge`): exit 0 with every
output written, or exit 2 with one line; never exit 3 or a traceback; a refusal writes no output
and leaves the history's bytes as they were; a command that succeeds loses no record (every row
of the mutant is still there, unchanged, after it).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import random
import re
import shutil
import signal
import sqlite3
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROBOT = "R1"
OTHER = "R2"
COLUMNS = ("robot_id", "kind", "recorded_at", "robocal_version", "model_yaml", "model_sha256", "summary",
           "parameters", "uncertainty", "data", "parent_id")
HOSTILE_TEXT = ["", " ", "R1\n", "R1\x00", "</script><script>alert(1)</script>", "]]>", "-->", "\x1b[2J",
                "x" * 100_000, "\u202e1R", "'; DROP TABLE records; --", "NaN", "1e999"]
HOSTILE_JSON = ["{", "[]", "{}", "null", "1", '"x"', "NaN", '{"rms": NaN}', '{"rms": Infinity}',
                '{"rms": 1e999}', '{"rms": "0.1"}', '{"rms": true}', '{"rms": -1}', '{"rms": 1e308}',
                "[" * 50_000 + "]" * 50_000, '{"a": ' * 3000 + "1" + "}" * 3000,
                '{"verdict": "holds", "p_value": 2}', '{"verdict": "<b>x</b>", "p_value": 0.5}',
                '{"rms": 0.1, "changed_parameters": [{"name": "<script>", "unit": "mm", "shift": 1, '
                '"sigma": 1}]}',
                '{"names": ["a"], "covariance": [[1e308]], "noise_m": 1e-5, "dof": 3}',
                '{"names": ["a"], "covariance": [[-1]], "noise_m": 1e-5, "dof": 3}',
                '{"names": ["a", "b"], "covariance": [[1, 2], [3, 4]], "noise_m": 1e-5, "dof": 3}',
                '{"names": [], "covariance": [], "noise_m": 1e-5, "dof": 3}',
                '[{"file": "<script>alert(1)</script>\\n", "role": "-->", "sha256": "]]>"}]',
                '[{"name": "a\\nb", "unit": "<i>", "estimate": 1e300, "sigma": null}]']
HOSTILE_NUMBERS = [None, 0, -1, 2**63 - 1, -(2**63), 1e308, float("nan"), float("inf"), 1.5, "1", b"\x00\x01",
                   True]
SCHEMA_SQL = [
    "CREATE TRIGGER t_wipe AFTER INSERT ON records BEGIN DELETE FROM records WHERE id <> NEW.id; END",
    "CREATE TRIGGER t_nohist BEFORE INSERT ON records BEGIN SELECT RAISE(ABORT, 'no'); END",
    "CREATE TRIGGER t_upd AFTER INSERT ON records BEGIN UPDATE records SET robot_id = 'gone'; END",
    "CREATE TABLE other_app (x)",
    "CREATE VIEW v AS SELECT * FROM records",
    "DROP INDEX records_robot",
    "DROP TABLE records",
    "DROP TABLE schema_version",
    "DELETE FROM schema_version",
    "INSERT INTO schema_version VALUES (1)",
    "UPDATE schema_version SET version = 0",
    "UPDATE schema_version SET version = 99",
    "UPDATE schema_version SET version = '1'",
    "UPDATE schema_version SET version = NULL",
    "CREATE INDEX records_bad ON records (kind)",
    "ALTER TABLE records ADD COLUMN extra TEXT DEFAULT 'x'",
    "ALTER TABLE records RENAME COLUMN summary TO summary_old",
    "ALTER TABLE records DROP COLUMN parent_id",
    "PRAGMA journal_mode=WAL",
    "PRAGMA user_version=7",
    "PRAGMA application_id=1234",
    "UPDATE records SET parent_id = id",
    "UPDATE records SET parent_id = 9999",
    "UPDATE records SET id = id + 1000",
    "UPDATE records SET robot_id = 'r1'",
    "UPDATE records SET robot_id = ' R1'",
    "UPDATE records SET kind = 'CALIBRATION'",
    "DELETE FROM records WHERE kind = 'calibration'",
    "DELETE FROM records",
    "INSERT INTO records (robot_id, kind, recorded_at, robocal_version, model_yaml, model_sha256, summary, "
    "parameters, uncertainty, data, parent_id) SELECT robot_id, kind, recorded_at, robocal_version, "
    "model_yaml, model_sha256, summary, parameters, uncertainty, data, parent_id FROM records",
    "UPDATE records SET recorded_at = '2099-01-01T00:00:00+00:00'",
    "UPDATE records SET recorded_at = '2020-01-01T00:00:00'",
    "UPDATE records SET recorded_at = '0001-01-01'",
    "UPDATE sqlite_sequence SET seq = 9223372036854775807",
    "DELETE FROM sqlite_sequence",
]


@dataclass
class Seed:
    """The files a mutant runs against: the history and the inputs of the commands."""

    folder: Path
    history: Path
    model: Path  # the calibrated model (calibrate's output)
    cal: Path
    check: Path


def make_seed(folder: Path) -> Seed:
    """A real history (calibrate, check, evaluate of ROBOT; calibrate of OTHER) through the CLI."""
    import robocal as rc
    from robocal.cli import main
    from robocal.data.simulate import sample_joints, simulate_tracker

    folder.mkdir(parents=True, exist_ok=True)
    nominal = rc.Robot.from_catalog("ur5e")
    sim = simulate_tracker(nominal, 40, seed=21)
    sim.data.save(folder / "cal.csv")
    joints = sample_joints(sim.truth, 15, np.random.default_rng(3))
    simulate_tracker(sim.truth, joints=joints, as_is=True, seed=3).data.save(folder / "check.csv")
    hist = folder / "h.sqlite"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        for rid in (ROBOT, OTHER):
            assert main(["--quiet", "calibrate", str(folder / "cal.csv"), "--robot", "ur5e", "--nongeometric",
                         "none", "-o", str(folder / "cal.yaml"), "--history", str(hist),
                         "--robot-id", rid]) == 0
        assert main(["--quiet", "check", str(folder / "cal.yaml"), str(folder / "check.csv"), "--history",
                     str(hist), "--robot-id", ROBOT]) == 0
        assert main(["--quiet", "evaluate", str(folder / "cal.yaml"), str(folder / "check.csv"), "--history",
                     str(hist), "--robot-id", ROBOT]) == 0
    return Seed(folder, hist, folder / "cal.yaml", folder / "cal.csv", folder / "check.csv")


# -- mutation ------------------------------------------------------------------------------------
def _sql_ops(path: Path, rng: random.Random) -> str:
    """One SQL-level change of the history at ``path``; returns its description."""
    conn = sqlite3.connect(path, isolation_level=None)
    try:
        ids = [r[0] for r in conn.execute("SELECT id FROM records")]
        op = rng.random()
        if op < 0.15 and ids:  # one figure inside a record's JSON scaled, negated or made whole and huge
            ident, column = rng.choice(ids), rng.choice(["summary", "uncertainty", "parameters"])
            text = conn.execute(f"SELECT {column} FROM records WHERE id = ?", (ident,)).fetchone()[0]
            if not isinstance(text, str):
                return f"record {ident} {column}: not text"
            spots = list(re.finditer(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?", text))
            if not spots:
                return f"record {ident} {column}: no number"
            m = rng.choice(spots)
            value = rng.choice(["1e300", "-1e300", "1e-300", "0", "-1", str(10**30), str(-float(m.group()))])
            conn.execute(f"UPDATE records SET {column} = ? WHERE id = ?",
                         (text[:m.start()] + value + text[m.end():], ident))
            return f"record {ident} {column}: {m.group()} -> {value}"
        if op < 0.6 and ids:
            ident, column = rng.choice(ids), rng.choice(COLUMNS)
            if column in ("summary", "parameters", "uncertainty", "data"):
                value = rng.choice(HOSTILE_JSON + HOSTILE_NUMBERS[:3])
            elif column == "parent_id":
                value = rng.choice(HOSTILE_NUMBERS + [rng.choice(ids)])
            else:
                value = rng.choice(HOSTILE_TEXT + HOSTILE_NUMBERS)
            if column == "model_yaml" and rng.random() < 0.5:  # a hostile model, fingerprinted to match
                value = rng.choice(["a: &a [*a]", "a: &a ['x','x']\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]\n"
                                    "c: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b]\nd: [*c,*c,*c,*c,*c,*c,*c,*c,*c]\n",
                                    "!!python/object/apply:os.system ['echo pwned']", "[" * 10000])
                conn.execute("UPDATE records SET model_yaml = ?, model_sha256 = ? WHERE id = ?",
                             (value, hashlib.sha256(value.encode()).hexdigest(), ident))
                return f"record {ident} model_yaml = {value[:40]!r} (fingerprint matched)"
            if isinstance(value, float) and not np.isfinite(value):
                conn.execute(f"UPDATE records SET {column} = ? WHERE id = ?", (value, ident))
            else:
                try:
                    conn.execute(f"UPDATE records SET {column} = ? WHERE id = ?", (value, ident))
                except sqlite3.IntegrityError:
                    return f"record {ident} {column}: refused by the schema"
            return f"record {ident} {column} = {value!r:.60}"
        sql = rng.choice(SCHEMA_SQL)
        try:
            conn.execute(sql)
        except sqlite3.Error as exc:
            return f"{sql[:60]} (failed: {exc})"
        return sql[:80]
    finally:
        conn.close()


def _byte_op(path: Path, rng: random.Random) -> str:
    """One byte-level change of the file at ``path``; returns its description."""
    data = bytearray(path.read_bytes())
    page = int.from_bytes(data[16:18], "big") or 4096
    pages = max(1, len(data) // page)
    op = rng.randrange(6)
    if op == 0:  # a random page overwritten with noise
        k = rng.randrange(pages)
        data[k * page:(k + 1) * page] = rng.randbytes(page)
        what = f"page {k + 1} overwritten"
    elif op == 1:  # a few bytes flipped
        for _ in range(rng.randint(1, 8)):
            i = rng.randrange(len(data))
            data[i] ^= 1 << rng.randrange(8)
        what = "bytes flipped"
    elif op == 2:
        cut = rng.randrange(len(data))
        del data[cut:]
        what = f"truncated at {cut}"
    elif op == 3:
        data += rng.randbytes(rng.choice([1, 100, page]))
        what = "grown"
    elif op == 4:  # the header changed (page size, counters, encoding)
        i = rng.randrange(16, 100)
        data[i] = rng.randrange(256)
        what = f"header byte {i}"
    else:  # an interior page zeroed
        k = rng.randrange(1, pages) if pages > 1 else 0
        data[k * page:(k + 1) * page] = bytes(page)
        what = f"page {k + 1} zeroed"
    path.write_bytes(bytes(data))
    return what


def mutate(seed: Seed, target: Path, rng: random.Random) -> list[str]:
    """Copy the seed history to ``target`` and change it by 1 to 3 operators; their descriptions."""
    shutil.copy(seed.history, target)
    done = []
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        if rng.random() < 0.7:
            try:
                done.append(_sql_ops(target, rng))
            except sqlite3.DatabaseError as exc:  # a file already damaged by a byte operator
                done.append(f"sql skipped ({exc})")
        else:
            done.append(_byte_op(target, rng))
    for extra in ("-wal", "-shm", "-journal"):
        Path(f"{target}{extra}").unlink(missing_ok=True)
    return done


# -- running ---------------------------------------------------------------------------------------
class _TimeoutError(Exception):
    pass


def _alarm(signum, frame):
    raise _TimeoutError


def run(argv: list[str], timeout_s: int = 120) -> tuple[int, str]:
    """Run the CLI in this process: (exit code, stderr); -1 a timeout, -2 an exception escaping."""
    from robocal.cli import main

    err = io.StringIO()
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(timeout_s)
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            code = main(["--quiet", *argv])
    except _TimeoutError:
        code = -1
    except BaseException:  # noqa: BLE001 - anything escaping main breaks the contract
        code = -2
        err.write(traceback.format_exc())
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return code, err.getvalue()


def rows(path: Path) -> dict | None:
    """The records of the history at ``path`` by id (a full scan), None when SQLite cannot read them."""
    try:
        with contextlib.closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as conn:
            cur = conn.execute("SELECT * FROM records NOT INDEXED")
            return {r[0]: r for r in cur.fetchall()}
    except sqlite3.Error:
        return None


def commands(seed: Seed, hist: Path, out: Path, calibrate: bool) -> dict[str, tuple[list[str], list[Path]]]:
    """Each command's argv and its outputs."""
    found = {
        "history": (["history", str(hist), "--robot-id", ROBOT, "--json", str(out / "t.json"), "--report",
                     str(out / "t.html")], [out / "t.json", out / "t.html"]),
        "check": (["check", str(seed.model), str(seed.check), "--history", str(hist), "--robot-id", ROBOT,
                   "--json", str(out / "c.json")], [out / "c.json"]),
        "evaluate": (["evaluate", str(seed.model), str(seed.check), "--history", str(hist), "--robot-id",
                      ROBOT, "--json", str(out / "e.json")], [out / "e.json"]),
    }
    if calibrate:
        found["calibrate"] = (["calibrate", str(seed.cal), "--robot", "ur5e", "--nongeometric", "none", "-o",
                               str(out / "n.yaml"), "--history", str(hist), "--robot-id", ROBOT],
                              [out / "n.yaml"])
    return found


def judge(code: int, stderr: str, outputs: list[Path], before_bytes: bytes, hist: Path,
          before_rows: dict | None, writes: bool) -> str | None:
    """None when the command kept the contract, else what broke it (one line)."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    if code in (-1, -2, 3) or code not in (0, 2):
        last = lines[-1] if lines else ""
        site = next((ln for ln in reversed(lines) if ln.strip().startswith("File ")), last)
        return f"exit {code}: {(lines[-1] if lines else '')[:200]} at {site.strip()[:160]}"
    if code == 2:
        noise = [ln for ln in lines[:-1] if not ln.lower().startswith(("warning", "robocal"))]
        if not lines or noise:
            return f"exit 2 with stray output: {(noise or [''])[0][:160]}"
        written = [o.name for o in outputs if o.exists()]
        if written:
            return f"exit 2 with partial output {written}: {lines[-1][:160]}"
        if hist.read_bytes() != before_bytes:
            return f"exit 2 but the history changed: {lines[-1][:160]}"
        return None
    missing = [o.name for o in outputs if not o.exists()]
    if missing:
        return f"exit 0 without {missing}"
    if not writes and hist.read_bytes() != before_bytes:
        return "a read changed the history"
    if writes and before_rows is not None:
        after = rows(hist)
        if after is None:
            return "exit 0 and the history unreadable after"
        lost = [i for i, r in before_rows.items() if after.get(i) != r]
        if lost:
            return f"exit 0 and records {lost} lost or changed"
        if len(after) != len(before_rows) + 1:
            return f"exit 0 with {len(after) - len(before_rows)} new records (1 expected)"
    return None


def fuzz_one(seed: Seed, folder: Path, rng: random.Random, calibrate: bool) -> list[str]:
    """One mutant through every command; the contract breaks, one line each."""
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    base = folder / "h.sqlite"
    what = mutate(seed, base, rng)
    mutant = base.read_bytes()
    problems = []
    for name, (argv, outputs) in commands(seed, folder / "h_run.sqlite", folder, calibrate).items():
        hist = folder / "h_run.sqlite"
        hist.write_bytes(mutant)
        for extra in ("-wal", "-shm", "-journal"):
            Path(f"{hist}{extra}").unlink(missing_ok=True)
        for o in outputs:
            o.unlink(missing_ok=True)
        before_rows = rows(hist)
        inputs = {p: p.read_bytes() for p in (seed.model, seed.cal, seed.check)}
        code, stderr = run(argv)
        problem = judge(code, stderr, outputs, mutant, hist, before_rows, writes=name != "history")
        if any(p.read_bytes() != b for p, b in inputs.items()):
            problem = "an input changed"
        if problem:
            problems.append(f"{name} on [{'; '.join(what)}]: {problem}")
    return problems


def main_loop(count: int, seed_value: int, folder: Path, calibrate_every: int = 4) -> list[str]:
    """``count`` mutants (seeded); every ``calibrate_every``-th also through calibrate."""
    seed = make_seed(folder / "seed")
    rng = random.Random(seed_value)
    problems = []
    for k in range(count):
        found = fuzz_one(seed, folder / "case", rng, k % calibrate_every == 0)
        problems += [f"mutant {k}: {p}" for p in found]
    return problems


if __name__ == "__main__":  # pragma: no cover - a quick manual run
    import sys
    import tempfile

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    with tempfile.TemporaryDirectory() as tmp:
        for line in main_loop(n, int(os.environ.get("SEED", "0")), Path(tmp)):
            print(line, flush=True)
