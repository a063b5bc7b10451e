"""The all-or-none writer under injected faults: an I/O error, a full disk or an interrupt (a
real SIGINT or SIGTERM sent to the process) at every step of the write, kill -9 and two
processes racing for the same outputs. After each fault every output holds its whole old
content or every one its new content, and no temporary file is left."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import children
import pytest

import robocal.core.io as rio
from robocal.core.errors import DataError
from robocal.core.io import write_all

SRC = Path(rio.__file__).resolve().parents[1]  # src/robocal: children import robocal.core.io alone (fast)
_CHILD_PRELUDE = f"""
import sys, types
pkg = types.ModuleType("robocal"); pkg.__path__ = [{str(SRC)!r}]; sys.modules["robocal"] = pkg
from robocal.core.io import write_all, _FolderLocks
"""


class _Injector:
    """Counts the steps of a write (file-system calls robocal.core.io makes) and acts at step ``n``:
    ``kind`` is 'eio' / 'enospc' (that call raises OSError) or 'sigint' / 'sigterm' (a real signal
    is sent to this process just before the call, which then runs)."""

    STEPS = {"os": ("replace", "link", "fsync", "chmod"), "tempfile": ("mkstemp",)}

    def __init__(self, monkeypatch, n: int, kind: str) -> None:
        self.n, self.kind, self.count, self.acted = n, kind, 0, False
        for module, names in self.STEPS.items():
            target = os if module == "os" else tempfile
            for name in names:
                monkeypatch.setattr(target, name, self._wrap(getattr(target, name)))
        real_fdopen = os.fdopen
        injector = self

        class _File:  # a file whose write() is one more step
            def __init__(self, fh):
                self.fh = fh

            def __enter__(self):
                return self

            def __exit__(self, *exc):
                self.fh.close()

            def write(self, data):
                injector._step()
                return self.fh.write(data)

            def __getattr__(self, name):
                return getattr(self.fh, name)

        monkeypatch.setattr(os, "fdopen", lambda fd, *a, **k: _File(real_fdopen(fd, *a, **k)))

    def _step(self) -> None:
        self.count += 1
        if self.count != self.n:
            return
        self.acted = True
        if self.kind in ("eio", "enospc"):
            code = errno.EIO if self.kind == "eio" else errno.ENOSPC
            raise OSError(code, os.strerror(code))
        os.kill(os.getpid(), signal.SIGINT if self.kind == "sigint" else signal.SIGTERM)

    def _wrap(self, real):
        def step(*args, **kwargs):
            self._step()
            return real(*args, **kwargs)
        return step


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


# (outputs that exist before, outputs that do not): sets of one, two and three files
SCENARIOS = [(("a.yaml",), ()), ((), ("a.yaml",)), (("a.yaml", "b.json"), ()),
             (("a.yaml",), ("b.json", "c.html")), (("a.yaml", "b.json", "c.html"), ())]
KINDS = ("eio", "enospc", "sigint", "sigterm")


def _clean_steps(tmp_path: Path, monkeypatch, scenario) -> int:
    """How many steps a write of ``scenario`` takes when nothing fails."""
    folder = tmp_path / "count"
    folder.mkdir()
    old, new = scenario
    for name in old:
        (folder / name).write_text("old")
    with monkeypatch.context() as m:
        injector = _Injector(m, 0, "eio")
        write_all({folder / name: "new" for name in (*old, *new)})
    return injector.count


@pytest.mark.slow
def test_a_fault_at_every_step_leaves_all_old_or_all_new(tmp_path, monkeypatch):
    class TerminatedError(Exception):
        pass

    def on_sigterm(signum, frame):
        raise TerminatedError

    previous = signal.signal(signal.SIGTERM, on_sigterm)
    faults = 0
    try:
        for s, scenario in enumerate(SCENARIOS):
            old, new = scenario
            (tmp_path / f"s{s}").mkdir()
            steps = _clean_steps(tmp_path / f"s{s}", monkeypatch, scenario)
            assert steps >= 3 * len(old + new)
            for kind in KINDS:
                for n in range(1, steps + 1):
                    folder = tmp_path / f"s{s}" / f"{kind}{n}"
                    folder.mkdir()
                    for i, name in enumerate(old):
                        (folder / name).write_bytes(f"old {name} {i}\n".encode() * 50)
                    before = _snapshot(folder)
                    contents = {folder / name: f"new {name}\n" * 70 for name in (*old, *new)}
                    after = {p.name: c.encode() for p, c in contents.items()}
                    with monkeypatch.context() as m:
                        injector = _Injector(m, n, kind)
                        expected = {"eio": DataError, "enospc": DataError, "sigint": KeyboardInterrupt,
                                    "sigterm": TerminatedError}[kind]
                        with pytest.raises(expected):
                            write_all(contents)
                    assert injector.acted
                    faults += 1
                    state = _snapshot(folder)
                    assert state == before, (scenario, kind, n, state)
                    # and the folder is usable again: the next write goes through
                    write_all(contents)
                    assert _snapshot(folder) == after
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert faults >= 200


def test_an_interrupt_during_restore_does_not_lose_the_old_output(tmp_path, monkeypatch):
    """The second rename fails; the restore of the first output is one more rename (which works)."""
    a, b = tmp_path / "a", tmp_path / "b"
    a.write_text("old a")
    b.write_text("old b")
    real = os.replace
    calls = []

    def flaky(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise OSError(errno.EIO, "Input/output error")
        return real(src, dst)

    monkeypatch.setattr(os, "replace", flaky)
    with pytest.raises(DataError, match=r"cannot write .*b: Input/output error"):
        write_all({a: "new a", b: "new b"})
    assert _snapshot(tmp_path) == {"a": b"old a", "b": b"old b"}
    assert len(calls) == 3  # a replaced, b failed, a restored


def test_a_failed_restore_is_named_and_keeps_the_old_content(tmp_path, monkeypatch):
    """A disk that stops renaming after the first one: the message says where the old copy is."""
    a, b = tmp_path / "a", tmp_path / "b"
    a.write_text("old a")
    real = os.replace
    calls = []

    def dying(src, dst):
        calls.append(dst)
        if len(calls) > 1:
            raise OSError(errno.EROFS, "Read-only file system")
        return real(src, dst)

    monkeypatch.setattr(os, "replace", dying)
    with pytest.raises(DataError, match="restoring the old content failed") as err:
        write_all({a: "new a", b: "new b"})
    assert "\n" not in str(err.value)
    kept = [p for p in tmp_path.iterdir() if p.name.endswith(rio.BACKUP_SUFFIX)]
    assert len(kept) == 1 and kept[0].read_text() == "old a" and kept[0].name in str(err.value)
    monkeypatch.setattr(os, "replace", real)
    write_all({a: "newer a"})  # the next run cleans the stale backup
    assert _snapshot(tmp_path) == {"a": b"newer a"}


def test_stale_temporaries_of_a_killed_run_are_removed_and_others_kept(tmp_path):
    out = tmp_path / "cal.yaml"
    out.write_text("old")
    suffixes = (rio.TEMP_SUFFIX, rio.BACKUP_SUFFIX)
    stale = [tmp_path / f".cal.yaml.x{i}{suffix}" for i, suffix in enumerate(suffixes)]
    mine = [tmp_path / ".cal.yaml.swp", tmp_path / ".other.yaml.x1.robocal.tmp", tmp_path / "notes.txt"]
    for p in (*stale, *mine):
        p.write_text("x")
    write_all({out: "new"})
    assert out.read_text() == "new"
    assert not any(p.exists() for p in stale) and all(p.exists() for p in mine)


def test_a_folder_named_like_a_stale_temporary_is_the_users_and_stays(tmp_path):
    out = tmp_path / "cal.yaml"
    folders = [tmp_path / f".cal.yaml.keep{suffix}" for suffix in (rio.TEMP_SUFFIX, rio.BACKUP_SUFFIX)]
    for folder in folders:
        folder.mkdir()
        (folder / "data.csv").write_text("the user's")
    link = tmp_path / f".cal.yaml.link{rio.TEMP_SUFFIX}"
    link.symlink_to(folders[0], target_is_directory=True)  # a stale link: removed, its folder kept
    write_all({out: "new"})
    write_all({out: "newer"})
    assert out.read_text() == "newer" and not link.is_symlink()
    assert all((folder / "data.csv").read_text() == "the user's" for folder in folders)


def test_the_written_file_is_fsynced_before_it_replaces_the_target(tmp_path, monkeypatch):
    events = []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(os, "fsync", lambda fd: (events.append("fsync"), real_fsync(fd))[1])
    monkeypatch.setattr(os, "replace", lambda s, d: (events.append("replace"), real_replace(s, d))[1])
    write_all({tmp_path / "a": "1", tmp_path / "b": "2"})
    assert events[:2] == ["fsync", "fsync"] and events[2:4] == ["replace", "replace"]
    assert events[4:] == ["fsync"]  # the folder, after the renames


def test_an_ignored_sigint_stays_ignored_during_a_write(tmp_path, monkeypatch):
    """A background job ignores SIGINT: a write neither catches it nor abandons the set for it."""
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    real_replace = os.replace

    def replace_after_a_sigint(src, dst):
        signal.raise_signal(signal.SIGINT)  # ignored: the write goes on
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace_after_a_sigint)
    try:
        write_all({tmp_path / "a": "new a", tmp_path / "b": "new b"})
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)
    assert (tmp_path / "a").read_text() == "new a" and (tmp_path / "b").read_text() == "new b"


_SIGNAL_CHILD = _CHILD_PRELUDE + """
import os, signal
from pathlib import Path
# a child inherits an ignored SIGINT (pytest run in the background: `make test &`, nohup, CI) and
# Python then leaves it ignored: between two writes every SIGINT would be dropped and the test wait
# for an answer forever (it hung 9 minutes). The child is an interactive program: Ctrl-C raises.
signal.signal(signal.SIGINT, signal.default_int_handler)
folder = Path(sys.argv[1])
names = ["cal.yaml", "result.json", "report.html"]
gen = 0
sys.stdout.write("ready\\n"); sys.stdout.flush()
while True:
    gen += 1
    try:
        write_all({folder / n: f"{gen} {n}\\n" * 2000 for n in names})
    except KeyboardInterrupt:
        sys.stdout.write("interrupted\\n"); sys.stdout.flush()
"""


def _consistent(folder: Path, names) -> bool:
    texts = [(folder / n).read_text() for n in names]
    gens = {t.split(" ", 1)[0] for t in texts}
    whole = all(t == f"{t.split(' ', 1)[0]} {n}\n" * 2000 for t, n in zip(texts, names, strict=True))
    return len(gens) == 1 and whole


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_real_signals_at_random_moments_leave_a_consistent_set(tmp_path, sig):
    """A process rewriting a set of three outputs in a loop gets the signal at a random moment:
    SIGINT (caught, the loop goes on, and it is sent again) or SIGTERM (the process ends)."""
    import random
    import time

    rng = random.Random(sig)
    names = ["cal.yaml", "result.json", "report.html"]
    runs = 12 if sig == signal.SIGINT else 6
    write_all({tmp_path / n: f"0 {n}\n" * 2000 for n in names})  # the outputs before the runs
    child = None
    interrupted = 0  # SIGINTs that landed inside write_all and came back as KeyboardInterrupt
    for run in range(runs):
        if child is None or child.poll() is not None:
            child = subprocess.Popen([sys.executable, "-c", _SIGNAL_CHILD, str(tmp_path)],
                                     stdout=subprocess.PIPE, text=True)
            assert children.read_line(child, "say it is ready") == "ready\n"
        time.sleep(rng.uniform(0.0, 0.05))
        child.send_signal(sig)
        if sig == signal.SIGTERM:
            assert children.wait(child, "end on SIGTERM", 10) == -signal.SIGTERM
        else:
            answer = children.read_line(child, f"answer SIGINT {run + 1}")
            if answer == "" and children.wait(child) == -signal.SIGINT:
                continue  # it came between two writes (outside the child's try), not inside write_all
            assert answer == "interrupted\n"
            interrupted += 1
        if run and (sig == signal.SIGTERM):
            assert _consistent(tmp_path, names)
            assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names)
    # the window between two writes is a few microseconds against a write's milliseconds: most
    # SIGINTs must have been caught inside write_all (the assertion every run made before)
    assert sig != signal.SIGINT or interrupted > runs // 2, f"{interrupted} of {runs} SIGINTs caught"
    child.send_signal(signal.SIGTERM)
    children.wait(child, "end on SIGTERM", 10)
    assert _consistent(tmp_path, names)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names)


def test_kill_9_leaves_whole_files_and_the_next_run_cleans_up(tmp_path):
    import time

    names = ["cal.yaml", "result.json", "report.html"]
    for run in range(3):
        child = subprocess.Popen([sys.executable, "-c", _SIGNAL_CHILD, str(tmp_path)],
                                 stdout=subprocess.PIPE, text=True)
        assert children.read_line(child, "say it is ready") == "ready\n"
        time.sleep(0.02 * run)
        child.kill()
        children.wait(child, "end on SIGKILL", 10)
        for n in names:  # each file whole (a set may mix generations: the documented limit)
            if (tmp_path / n).exists():
                text = (tmp_path / n).read_text()
                assert text == f"{text.split(' ', 1)[0]} {n}\n" * 2000
    write_all({tmp_path / n: "final" for n in names})
    assert _snapshot(tmp_path) == {n: b"final" for n in names}


_RACE_CHILD = _CHILD_PRELUDE + """
from pathlib import Path
folder, tag, rounds = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3])
names = ["cal.yaml", "result.json", "report.html"]
bad = 0
for i in range(rounds):
    write_all({folder / n: f"{tag}{i} {n}\\n" * 500 for n in names})
    with _FolderLocks([folder / n for n in names]):  # a reader that takes the writers' lock
        texts = [(folder / n).read_text() for n in names]
        gens = {t.split(" ", 1)[0] for t in texts}
        bad += len(gens) != 1 or any(t != f"{t.split(' ', 1)[0]} {n}\\n" * 500 for t, n in zip(texts, names))
print(bad)
"""


def test_two_processes_racing_for_the_same_outputs_never_mix_them(tmp_path):
    rounds = 25
    racers = [subprocess.Popen([sys.executable, "-c", _RACE_CHILD, str(tmp_path), tag, str(rounds)],
                               stdout=subprocess.PIPE, text=True) for tag in "AB"]
    outs = [children.communicate(c, f"finish {rounds} rounds")[0] for c in racers]
    assert [c.returncode for c in racers] == [0, 0]
    assert [int(o) for o in outs] == [0, 0]  # 2 x 25 writes, every one checked under the lock
    names = ["cal.yaml", "result.json", "report.html"]
    final = {(tmp_path / n).read_text().split(" ", 1)[0] for n in names}
    assert final in ({f"A{rounds - 1}"}, {f"B{rounds - 1}"})
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names)


def test_a_writer_waits_for_another_and_then_refuses_with_one_line(tmp_path, monkeypatch):
    import fcntl

    monkeypatch.setattr(rio, "LOCK_TIMEOUT_S", 0.1)
    fd = os.open(tmp_path, os.O_RDONLY)
    try:
        holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
            import fcntl, os, sys, time
            fd = os.open({str(tmp_path)!r}, os.O_RDONLY); fcntl.flock(fd, fcntl.LOCK_EX)
            print("locked", flush=True); time.sleep(30)""")], stdout=subprocess.PIPE, text=True)
        assert children.read_line(holder, "say it holds the lock") == "locked\n"
        with pytest.raises(DataError, match="another robocal process") as err:
            write_all({tmp_path / "a": "x"})
        assert "\n" not in str(err.value) and not (tmp_path / "a").exists()
        holder.kill()
        children.wait(holder, "end on SIGKILL", 10)
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # released with its process
    finally:
        os.close(fd)
    write_all({tmp_path / "a": "x"})
    assert (tmp_path / "a").read_text() == "x"


def test_an_output_named_as_a_history_is_refused_through_the_python_api_too(tmp_path):
    """A Python caller's ``write()`` over a robocal history (no CLI's --history to compare with) is
    refused by the write itself: the database is left byte for byte as it was."""
    import robocal as rc
    from robocal.history.store import History

    hist = tmp_path / "cell7.sqlite"
    with History(str(hist)):
        pass
    before = hist.read_bytes()
    robot = rc.Robot.from_catalog("abb_irb2600")
    with pytest.raises(rc.DataError, match="SQLite database"):
        robot.save(hist)
    assert hist.read_bytes() == before
    robot.save(tmp_path / "fine.yaml")  # an ordinary output still written
