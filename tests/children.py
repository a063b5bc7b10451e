"""Waiting on child processes with a deadline: a child that stops answering is killed and the test
fails saying what it waited for, instead of hanging the suite (issue 43: a SIGINT test waited
9 minutes on a child's output).

``read_line``, ``wait`` and ``communicate`` take the ``subprocess.Popen`` child, a deadline in
seconds and a few words naming what the test waits for.
"""

from __future__ import annotations

import subprocess
import threading
from pathlib import Path

import pytest

TIMEOUT_S = 60.0  # a child's answer on a busy 2-core machine; far beyond what any of them needs


def _signal_state(pid: int) -> str:
    """The process state and signal masks Linux shows for ``pid`` ('' elsewhere): which signals
    a child that stopped answering blocks (SigBlk), ignores (SigIgn) or catches (SigCgt)."""
    try:
        lines = Path(f"/proc/{pid}/status").read_text().splitlines()
    except OSError:
        return ""
    keep = ("State:", "SigBlk:", "SigIgn:", "SigCgt:")
    return "; " + ", ".join(" ".join(line.split()) for line in lines if line.startswith(keep))


def _give_up(child: subprocess.Popen, what: str, timeout_s: float) -> None:
    state = "still running" if child.poll() is None else f"exit code {child.returncode}"
    state += _signal_state(child.pid) if child.returncode is None else ""
    child.kill()
    child.wait()
    pytest.fail(f"the child process ({state}) did not {what} within {timeout_s:g} s: killed", pytrace=False)


def read_line(child: subprocess.Popen, what: str, timeout_s: float = TIMEOUT_S) -> str:
    """The next line of the child's stdout (with its newline; '' at the end of the output). The
    read runs in a thread: a line already in the pipe's buffer is found at once, whatever the
    buffering."""
    got: list[str] = []
    reader = threading.Thread(target=lambda: got.append(child.stdout.readline()), daemon=True)
    reader.start()
    reader.join(timeout_s)
    if not got:
        _give_up(child, what, timeout_s)  # closing the pipe ends the reader thread
    return got[0]


def wait(child: subprocess.Popen, what: str = "exit", timeout_s: float = TIMEOUT_S) -> int:
    """The child's exit code (negative: the signal that ended it)."""
    try:
        return child.wait(timeout_s)
    except subprocess.TimeoutExpired:
        _give_up(child, what, timeout_s)
        raise  # not reached: pytest.fail raised


def communicate(child: subprocess.Popen, what: str = "finish",
                timeout_s: float = TIMEOUT_S) -> tuple[str | None, str | None]:
    """The child's whole (stdout, stderr) once it has exited."""
    try:
        return child.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        _give_up(child, what, timeout_s)
        raise  # not reached: pytest.fail raised
