"""A Ctrl-C is never lost (issue 47, cause 5): a process rewriting its outputs in a loop stopped
answering SIGINT after one came at an unlucky moment. Each race of the signal deferral of
:mod:`robocal.core.io` and of the command line's SIGINT handler is forced here at its exact moment
(a handler of another signal raising inside ``signal.signal`` or ``pthread_sigmask``, a signal
taken while the handlers are put back, writes that nest or close out of order, a deferring
handler left installed), then real signals are sent at random moments to a child process, many
times, every wait with a deadline: every SIGINT is answered, the last one ends the child, and the
outputs are whole (all old or all new)."""

from __future__ import annotations

import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import children
import pytest

import robocal.core.io as rio
from robocal.cli import main
from robocal.core.io import write_all

SRC = Path(rio.__file__).resolve().parents[1]
DEFERRED = (signal.SIGINT, signal.SIGTERM)


class RaisedError(Exception):
    """What a handler of another signal raises (a timeout's SIGALRM handler, say)."""


@pytest.fixture(autouse=True)
def python_handlers():
    """Each case starts from Python's own handlers (a background pytest inherits SIGINT ignored)
    and leaves them so; the mask of this thread unchanged."""
    before = {sig: signal.getsignal(sig) for sig in DEFERRED}
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, ())
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    yield
    for sig, handler in before.items():
        signal.signal(sig, handler)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def _answers_ctrl_c() -> None:
    """This process answers SIGINT with KeyboardInterrupt, SIGTERM has its default, nothing is
    blocked and no write is open."""
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    assert not set(DEFERRED) & signal.pthread_sigmask(signal.SIG_BLOCK, ())
    assert not rio._DEFERRAL.writes
    with pytest.raises(KeyboardInterrupt):
        signal.raise_signal(signal.SIGINT)


def _failing_swap(monkeypatch, call: int, after: bool, exc: BaseException):
    """``signal.signal`` whose ``call``-th call with a deferred signal raises ``exc``, before the
    swap (CPython runs the pending handlers first) or ``after`` it (the next bytecode)."""
    real = signal.signal
    calls = []

    def swap(sig, handler):
        if sig in DEFERRED:
            calls.append(sig)
            if len(calls) == call:
                if after:
                    real(sig, handler)
                raise exc
        return real(sig, handler)

    monkeypatch.setattr(signal, "signal", swap)
    return calls


@pytest.mark.parametrize("call", [1, 2])
@pytest.mark.parametrize("after", [False, True], ids=["before the swap", "after the swap"])
def test_a_handler_raising_while_the_deferral_starts(tmp_path, monkeypatch, call, after):
    """The old deferral swapped SIGINT, then SIGTERM's swap raised (a raising SIGTERM handler
    run first): the deferring SIGINT handler stayed, every later Ctrl-C noted by nobody."""
    _failing_swap(monkeypatch, call, after, RaisedError())
    with pytest.raises(RaisedError):
        write_all({tmp_path / "a": "new"})
    monkeypatch.undo()
    assert not (tmp_path / "a").exists()
    _answers_ctrl_c()


@pytest.mark.parametrize("call", [3, 4])
@pytest.mark.parametrize("after", [False, True], ids=["before the swap", "after the swap"])
def test_an_interrupt_while_the_handlers_are_put_back(tmp_path, monkeypatch, call, after):
    """A SIGINT taken by another thread while the handlers are put back runs the handler put back
    a moment before, inside the next ``signal.signal``: the rest are put back all the same."""
    _failing_swap(monkeypatch, call, after, KeyboardInterrupt())
    with pytest.raises(KeyboardInterrupt):
        write_all({tmp_path / "a": "new", tmp_path / "b": "new"})
    monkeypatch.undo()
    assert (tmp_path / "a").read_text() == (tmp_path / "b").read_text() == "new"  # done before
    _answers_ctrl_c()


@pytest.mark.parametrize("step", [2, 3, 4, 5])
def test_a_handler_raising_inside_pthread_sigmask(tmp_path, monkeypatch, step):
    """``pthread_sigmask`` runs the pending handlers after changing the mask; one that raises
    must not leave SIGINT blocked (the mask lost with the return value) nor the handlers swapped."""
    real = signal.pthread_sigmask
    calls = []

    def mask(how, signals):
        calls.append(how)
        result = real(how, signals)
        if len(calls) == step:
            raise RaisedError
        return result

    monkeypatch.setattr(signal, "pthread_sigmask", mask)
    with pytest.raises(RaisedError):
        write_all({tmp_path / "a": "new"})
    monkeypatch.undo()
    _answers_ctrl_c()


def test_a_deferring_handler_left_installed_delivers_the_next_ctrl_c():
    """Whatever left the deferring handler installed without an open write, the next SIGINT puts
    Python's handler back and reaches it."""
    rio._DEFERRAL.saved.update({signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL})
    for sig in DEFERRED:
        signal.signal(sig, rio._DEFERRAL.handler)
    with pytest.raises(KeyboardInterrupt):
        signal.raise_signal(signal.SIGINT)
    _answers_ctrl_c()


def test_nested_and_overlapping_writes_share_one_deferral(tmp_path):
    """A write inside another (and two closed out of order) save Python's handlers once, never a
    deferring one: after the last closes Ctrl-C is answered, a SIGINT noted meanwhile delivered."""
    outer, inner = rio._DeferSignals(), rio._DeferSignals()
    outer.__enter__()
    inner.__enter__()
    write_all({tmp_path / "a": "new"})  # a third, nested
    signal.raise_signal(signal.SIGINT)  # noted
    with pytest.raises(KeyboardInterrupt):
        inner.check()
    outer.__exit__(None, None, None)  # out of order: the inner one is still open
    assert signal.getsignal(signal.SIGINT) == rio._DEFERRAL.handler
    with pytest.raises(KeyboardInterrupt):
        inner.__exit__(None, None, None)  # the last: handlers back, the noted SIGINT delivered
    _answers_ctrl_c()


def test_sigterm_noted_with_a_sigint_is_not_hidden_by_it(tmp_path, monkeypatch):
    """Both signals noted during one write: SIGTERM is delivered first (the old order raised the
    KeyboardInterrupt and never delivered the SIGTERM)."""
    def on_sigterm(signum, frame):
        raise RaisedError

    signal.signal(signal.SIGTERM, on_sigterm)
    real_replace = rio.os.replace

    def replace(src, dst):
        signal.raise_signal(signal.SIGINT)
        signal.raise_signal(signal.SIGTERM)
        real_replace(src, dst)

    monkeypatch.setattr(rio.os, "replace", replace)
    (tmp_path / "a").write_text("old")
    with pytest.raises(RaisedError):
        write_all({tmp_path / "a": "new", tmp_path / "b": "new"})
    monkeypatch.undo()
    assert (tmp_path / "a").read_text() == "old" and not (tmp_path / "b").exists()
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _answers_ctrl_c()


def test_the_command_line_handler_is_put_back_when_ctrl_c_comes_as_it_ends(monkeypatch, capsys):
    """The command line's own SIGINT handler raised inside ``signal.signal`` while being put back:
    it stayed installed, and the interrupt escaped main() as a traceback. Now: 130, one line."""
    _failing_swap(monkeypatch, 2, False, KeyboardInterrupt())
    assert main(["robots"]) == 130
    monkeypatch.undo()
    assert capsys.readouterr().err == "robocal robots: interrupted\n"
    _answers_ctrl_c()


_LOOP_CHILD = f"""
import sys, types
pkg = types.ModuleType("robocal"); pkg.__path__ = [{str(SRC)!r}]; sys.modules["robocal"] = pkg
import signal, threading, time
from pathlib import Path
from robocal.core.io import write_all
signal.signal(signal.SIGINT, signal.default_int_handler)  # an interactive program (see test_io_faults)
folder, answers, busy = Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3] == "busy"
if busy:  # signals may be taken by another thread (numpy's BLAS threads in the command line)
    threading.Thread(target=lambda: [time.sleep(0.0002) for _ in iter(int, 1)], daemon=True).start()
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(143))  # a Python SIGTERM handler
names = ["cal.yaml", "result.json", "report.html"]
gen = int((folder / names[0]).read_text().split(" ", 1)[0])
sys.stdout.write("ready\\n"); sys.stdout.flush()
while True:
    try:
        gen += 1
        write_all({{folder / n: f"{{gen}} {{n}}\\n" * 500 for n in names}})
    except KeyboardInterrupt:
        answers -= 1
        if answers < 0:
            raise  # the last Ctrl-C ends the process
        sys.stdout.write("interrupted\\n"); sys.stdout.flush()
"""
NAMES = ["cal.yaml", "result.json", "report.html"]


def _whole(folder: Path) -> None:
    """All outputs of one generation, each whole; no temporary file left."""
    texts = [(folder / n).read_text() for n in NAMES]
    gen = texts[0].split(" ", 1)[0]
    assert texts == [f"{gen} {n}\n" * 500 for n in NAMES], "outputs of different generations or cut"
    assert sorted(p.name for p in folder.iterdir()) == sorted(NAMES)


def _ctrl_c_at_random_moments(folder: Path, signals: int, busy: bool, seed: int) -> int:
    """Children rewriting the outputs get SIGINTs at random moments (each answered, the last
    ending the child) until ``signals`` were sent; returns how many were sent."""
    rng = random.Random(seed)
    write_all({folder / n: f"0 {n}\n" * 500 for n in NAMES})
    sent = 0
    while sent < signals:
        answers = rng.randint(0, 6)
        child = subprocess.Popen([sys.executable, "-c", _LOOP_CHILD, str(folder), str(answers),
                                  "busy" if busy else "plain"], stdout=subprocess.PIPE, text=True)
        assert children.read_line(child, "say it is ready", 30) == "ready\n"
        for k in range(answers + 1):
            time.sleep(rng.uniform(0.0, 0.004))
            child.send_signal(signal.SIGINT)
            sent += 1
            line = children.read_line(child, f"answer SIGINT {k + 1} of {answers + 1} (#{sent})", 20)
            if line == "":
                break  # ended by it (the last one, or one that came while the previous was answered)
            assert line == "interrupted\n" and k < answers
        assert children.wait(child, f"end on SIGINT #{sent}", 20) == -signal.SIGINT
        _whole(folder)
    return sent


def test_ctrl_c_at_random_moments_is_always_answered(tmp_path):
    """300 SIGINTs at random moments (about 10 s): every one answered, every child ended by its
    last, the outputs whole after each."""
    assert _ctrl_c_at_random_moments(tmp_path, 300, busy=False, seed=47) >= 300


@pytest.mark.slow
def test_ctrl_c_at_random_moments_with_other_threads_many_times(tmp_path):
    """The heavy variant: 1,000 SIGINTs to children with another thread running (a signal may be
    taken by it while the main thread blocks the signals) and a Python SIGTERM handler."""
    assert _ctrl_c_at_random_moments(tmp_path, 1000, busy=True, seed=4747) >= 1000
