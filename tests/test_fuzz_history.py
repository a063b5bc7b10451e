"""Mutated history databases through history, check, evaluate and calibrate --history
(tests/fuzz_history.py): exit 0 with every output and no record lost, or exit 2 in one line with
no output and the history's bytes unchanged. The reproducers of the defects the fuzzing found come
first; the default run has a seeded sample, the slow one 400 mutants (SEED=1 python
tests/fuzz_history.py 400 runs any number)."""

from __future__ import annotations

import json
import random
import shutil
import sqlite3
from contextlib import closing

import numpy as np
import pytest
from fuzz_history import ROBOT, commands, fuzz_one, judge, make_seed, mutate, rows, run

FAST = 12  # mutants in the default suite (each through every command; calibrate every 4th)
SLOW = 400


@pytest.fixture(scope="module")
def seed(tmp_path_factory):
    return make_seed(tmp_path_factory.mktemp("history_seed"))


def _mutant(seed, tmp_path, *sql: str):
    hist = tmp_path / "h.sqlite"
    shutil.copy(seed.history, hist)
    with closing(sqlite3.connect(hist, isolation_level=None)) as conn:
        for statement in sql:
            conn.execute(statement)
    return hist


def _through_every_command(seed, tmp_path, hist) -> list[str]:
    mutant = hist.read_bytes()
    problems = []
    for name, (argv, outputs) in commands(seed, hist, tmp_path, calibrate=True).items():
        hist.write_bytes(mutant)
        before = rows(hist)
        code, stderr = run(argv)
        problem = judge(code, stderr, outputs, mutant, hist, before, writes=name != "history")
        if problem:
            problems.append(f"{name}: {problem}")
    return problems


@pytest.mark.parametrize("trigger", [
    "AFTER INSERT ON records BEGIN DELETE FROM records WHERE id <> NEW.id; END",  # exit 0, records lost
    "AFTER INSERT ON records BEGIN UPDATE records SET robot_id = 'gone'; END",  # exit 0, records changed
    "BEFORE INSERT ON records BEGIN SELECT RAISE(ABORT, 'no'); END",  # exit 2 after the outputs were written
])
def test_a_history_with_a_trigger_is_refused_before_any_output(seed, tmp_path, trigger, capsys):
    hist = _mutant(seed, tmp_path, f"CREATE TRIGGER t {trigger}")
    assert not _through_every_command(seed, tmp_path, hist)
    code, stderr = run(commands(seed, hist, tmp_path, calibrate=False)["check"][0])
    assert code == 2 and "trigger" in stderr and "writes nothing" in stderr


def test_an_exhausted_record_id_counter_is_refused_not_called_a_full_disk(seed, tmp_path):
    hist = _mutant(seed, tmp_path, "UPDATE sqlite_sequence SET seq = 9223372036854775807")
    assert not _through_every_command(seed, tmp_path, hist)
    code, stderr = run(commands(seed, hist, tmp_path, calibrate=False)["evaluate"][0])
    assert code == 2 and "record id counter" in stderr and "full" not in stderr


def test_a_record_dated_year_one_is_left_out_of_the_timeline_plot(seed, tmp_path):
    """Was exit 3 (matplotlib: dates before year 1) in ``history --report``."""
    hist = _mutant(seed, tmp_path, "UPDATE records SET recorded_at = '0001-01-01' WHERE id = 3")
    assert not _through_every_command(seed, tmp_path, hist)


def test_a_failed_migration_of_a_wal_history_leaves_its_bytes(seed, tmp_path):
    """A WAL history (an older robocal's) whose schema cannot be migrated: the journal mode was
    switched before the write failed, so a refusal changed the file."""
    hist = _mutant(seed, tmp_path, "ALTER TABLE records DROP COLUMN parent_id",
                   "UPDATE schema_version SET version = 0", "PRAGMA journal_mode=WAL")
    assert not _through_every_command(seed, tmp_path, hist)


def test_a_wal_history_is_still_switched_back_when_written(seed, tmp_path):
    hist = _mutant(seed, tmp_path, "PRAGMA journal_mode=WAL")
    code, _ = run(commands(seed, hist, tmp_path, calibrate=False)["evaluate"][0])
    assert code == 0
    with closing(sqlite3.connect(f"file:{hist}?mode=ro", uri=True)) as conn:
        assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "delete"
    assert ROBOT in {r[1] for r in rows(hist).values()}


def test_mutated_histories_keep_the_contract(seed, tmp_path):
    rng = random.Random(0)
    problems = [p for k in range(FAST) for p in fuzz_one(seed, tmp_path / "case", rng, k % 4 == 0)]
    assert not problems, "\n".join(problems[:5])


@pytest.mark.slow
def test_many_mutated_histories_keep_the_contract(seed, tmp_path):
    rng = random.Random(1)
    problems = [p for k in range(SLOW) for p in fuzz_one(seed, tmp_path / "case", rng, k % 4 == 0)]
    assert not problems, "\n".join(problems[:5])


@pytest.mark.parametrize("row", ['{"name": "d1", "unit": "mm", "shift": 0.5}',  # exit 3: KeyError 'sigma'
                                 '{"name": "d1", "unit": "mm", "shift": 0.5, "sigma": null}'])
def test_a_check_whose_shift_lacks_its_sigma_is_a_bad_record(seed, tmp_path, row):
    """A flipped byte turned a key of a check's changed parameters: ``history`` (its report prints
    each shift with its sigma) failed with an internal error."""
    hist = _mutant(seed, tmp_path, "UPDATE records SET summary = json_set(summary, '$.verdict', 'changed', "
                   f"'$.changed_parameters', json('[{row}]')) WHERE kind = 'check'")
    assert not _through_every_command(seed, tmp_path, hist)
    argv, outputs = commands(seed, hist, tmp_path, calibrate=False)["history"]
    assert run(argv)[0] == 0
    assert 3 not in [e["id"] for e in json.loads(outputs[0].read_text())["entries"]]  # left out


def test_a_calibration_parameter_without_its_sigma_is_a_bad_record(seed, tmp_path):
    hist = _mutant(seed, tmp_path, "UPDATE records SET parameters = json_remove(parameters, '$[0].sigma') "
                   "WHERE id = 1")
    assert not _through_every_command(seed, tmp_path, hist)


@pytest.mark.parametrize("command, option", [("evaluate", "--json"), ("check", "--json"), ("calibrate", "-o"),
                                             ("calibrate", "--json"), ("calibrate", "--report")])
def test_an_output_named_as_the_history_is_refused_and_loses_nothing(seed, tmp_path, command, option):
    """``evaluate ... --history h.sqlite --json h.sqlite`` replaced every record with the JSON, then
    said the history was 'not a SQLite database' (exit 2)."""
    hist = _mutant(seed, tmp_path)
    argv, outputs = commands(seed, hist, tmp_path, calibrate=True)[command]
    at = argv.index(option) + 1 if option in argv else len(argv)
    argv = [*argv[:at], str(hist), *argv[at + 1:]] if option in argv else [*argv, option, str(hist)]
    before = hist.read_bytes()
    code, stderr = run(argv)
    assert code == 2 and "it is the history" in stderr and hist.read_bytes() == before
    assert not [o for o in outputs if o.exists() and o != hist]


def test_a_new_history_named_as_an_output_is_refused_before_it_is_made(seed, tmp_path):
    hist = tmp_path / "new.sqlite"
    argv = commands(seed, hist, tmp_path, calibrate=True)["calibrate"][0]
    argv[argv.index("-o") + 1] = str(hist)
    code, stderr = run(argv)
    assert code == 2 and "it is the history" in stderr and not hist.exists()


def _with_uncertainty(seed, tmp_path, change):
    hist = _mutant(seed, tmp_path)
    with closing(sqlite3.connect(hist)) as conn, conn:
        unc = json.loads(conn.execute("SELECT uncertainty FROM records WHERE id = 1").fetchone()[0])
        change(unc)
        conn.execute("UPDATE records SET uncertainty = ? WHERE id = 1", (json.dumps(unc),))
    return hist


def _scaled(factor):
    return lambda u: u.__setitem__("covariance", (np.array(u["covariance"]) * factor).tolist())


@pytest.mark.parametrize("label, change", [
    ("variances 1e300", _scaled(1e300)),
    ("negative variances", _scaled(-1.0)),
    ("asymmetric", lambda u: u.__setitem__("covariance", (np.array(u["covariance"]) + np.triu(
        np.full(np.shape(u["covariance"]), 1e-9))).tolist())),
    ("noise 1e300 m", lambda u: u.__setitem__("noise_m", 1e300)),
    ("noise 1e-300 m", lambda u: u.__setitem__("noise_m", 1e-300)),
    ("dof 1e30", lambda u: u.__setitem__("dof", 10**30)),
])
def test_a_calibration_uncertainty_no_calibration_makes_is_a_bad_record(seed, tmp_path, label, change):
    """Each made ``check`` end in an internal error (a Cholesky factor of a matrix without one, an
    overflow, an F distribution of 1e30 degrees of freedom)."""
    hist = _with_uncertainty(seed, tmp_path, change)
    assert not _through_every_command(seed, tmp_path, hist)
    code, stderr = run(commands(seed, hist, tmp_path, calibrate=False)["check"][0])
    assert code == 2 and "record #1" in stderr and "uncertainty" in stderr, stderr


def test_a_real_uncertainty_scaled_down_is_still_used(seed, tmp_path):
    hist = _with_uncertainty(seed, tmp_path, _scaled(1e-6))
    assert run(commands(seed, hist, tmp_path, calibrate=False)["check"][0])[0] == 0


@pytest.fixture(scope="module")
def result_json(seed, tmp_path_factory):
    folder = tmp_path_factory.mktemp("result")
    code, err = run(["calibrate", str(seed.cal), "--robot", "ur5e", "--nongeometric", "none", "-o",
                     str(folder / "m.yaml"), "--json", str(folder / "r.json")])
    assert code == 0, err
    return folder


def _set_all(key, value):
    return lambda r: [p.__setitem__(key, value) for p in r["parameters"] if p.get("sigma") is not None]


@pytest.mark.parametrize("label, change", [
    ("sigma null", _set_all("sigma", None)),  # exit 3: None / float
    ("rms 1e308", lambda r: r["after"].__setitem__("rms", 1e308)),  # exit 3: OverflowError
    ("correlation negated", lambda r: r["correlation"].__setitem__("matrix", (-np.array(
        r["correlation"]["matrix"])).tolist())),
])
def test_check_refuses_a_result_json_no_calibration_makes(seed, result_json, tmp_path, label, change):
    data = json.loads((result_json / "r.json").read_text())
    out = tmp_path / "c.json"
    argv = ["check", str(result_json / "m.yaml"), str(seed.check), "--json", str(out), "--result"]
    assert run([*argv, str(result_json / "r.json")])[0] == 0  # the file as written is used
    out.unlink()
    change(data)
    (tmp_path / "x.json").write_text(json.dumps(data))
    code, stderr = run([*argv, str(tmp_path / "x.json")])
    assert code == 2 and len(stderr.strip().splitlines()) == 1 and not (tmp_path / "c.json").exists(), stderr


def test_a_history_that_is_a_pipe_is_refused_by_what_it_is(seed, tmp_path):
    """A FIFO as --history: 'does not exist' (history) and an internal error (evaluate: disk I/O)."""
    import os

    fifo = tmp_path / "h.sqlite"
    os.mkfifo(fifo)
    for name in ("history", "evaluate", "check"):
        argv, outputs = commands(seed, fifo, tmp_path, calibrate=False)[name]
        code, stderr = run(argv)
        assert code == 2 and "not a regular file" in stderr and not any(o.exists() for o in outputs), stderr
    assert fifo.is_fifo()


def test_a_history_an_insert_fails_in_is_refused_before_any_output(seed, tmp_path):
    """Mutant 155 of seed 3 (a figure changed, a view added, header byte 35 changed: the first
    freelist trunk page now 11 of 18): SQLite's integrity check passes, but the record's insert
    failed ('malformed') after evaluate and check had written their outputs. Now a record-sized
    row is inserted and rolled back before any output (the file's bytes stay)."""
    rng = random.Random(3)
    for _ in range(156):
        what = mutate(seed, tmp_path / "h.sqlite", rng)
    assert "header byte 35" in what
    hist = tmp_path / "h.sqlite"
    with closing(sqlite3.connect(f"file:{hist}?mode=ro", uri=True)) as conn:
        assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    assert not _through_every_command(seed, tmp_path, hist)


def test_the_write_probe_leaves_a_sound_history_as_it_was(seed, tmp_path):
    from robocal.history.store import History

    hist = _mutant(seed, tmp_path)
    before = hist.read_bytes()
    with History(hist) as history:
        history.probe_write()
    assert hist.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["h.sqlite"]


def test_a_history_whose_check_constraint_only_a_writer_sees_broken_is_refused_first(seed, tmp_path):
    """Mutant 313 of seed 5 (a column added, bytes flipped): the integrity check on a read-only
    connection passes, on the writing one 'CHECK constraint failed in records'; evaluate and check
    wrote their outputs, then refused to record."""
    rng = random.Random(5)
    for _ in range(314):
        what = mutate(seed, tmp_path / "h.sqlite", rng)
    assert "bytes flipped" in what
    assert not _through_every_command(seed, tmp_path, tmp_path / "h.sqlite")
