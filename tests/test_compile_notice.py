"""The first-use line when the compiled kernels are built (robocal.kinematics.compile_notice):
said once, at a cache miss of a cached robocal kernel, on a terminal only; a run whose kernels load
from the disk cache says nothing."""

from __future__ import annotations

import io
import os
import pty
import subprocess
import sys
from types import SimpleNamespace

import pytest

pytest.importorskip("numba", reason="the compiled kernels are the optional fast extra")

from robocal.kinematics import compile_notice  # noqa: E402
from robocal.kinematics.compile_notice import MESSAGE, CompileNotice, is_cached_robocal_kernel  # noqa: E402


def compile_event(dispatcher) -> SimpleNamespace:
    return SimpleNamespace(data={"dispatcher": dispatcher})


def test_only_a_cached_robocal_kernel_counts():
    import numba

    from robocal.kinematics import fk_numba

    assert is_cached_robocal_kernel(fk_numba._fk_kernel)  # cache=True
    assert not is_cached_robocal_kernel(fk_numba.cos_sin)  # compiled into its callers, no cache of its own
    assert not is_cached_robocal_kernel(numba.njit(cache=True)(lambda x: x))  # not robocal's
    assert not is_cached_robocal_kernel(None)


def test_said_once_at_the_first_miss():
    from robocal.kinematics import fk_numba

    out = io.StringIO()
    notice = CompileNotice(out)
    notice.on_start(compile_event(fk_numba.cos_sin))
    assert out.getvalue() == ""
    notice.on_start(compile_event(fk_numba._fk_kernel))
    notice.on_start(compile_event(fk_numba._frames_kernel))
    assert out.getvalue() == MESSAGE + "\n"


def test_standard_error_not_a_terminal_stays_quiet(monkeypatch):
    from robocal.kinematics import fk_numba

    err = io.StringIO()  # isatty() is False: a log, a pipe, a test's capture
    monkeypatch.setattr(sys, "stderr", err)
    CompileNotice().on_start(compile_event(fk_numba._fk_kernel))
    assert err.getvalue() == ""
    assert compile_notice.install() is compile_notice.install()  # one listener per process


FK = ("import numpy as np, robocal as rc; "
      "rc.Robot.from_catalog('abb_irb2600').fk(np.zeros((3, 6)))")


def run_on_a_terminal(env: dict) -> str:
    """Run `FK` with its standard error on a pseudo-terminal; what it wrote there."""
    leader, follower = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-c", FK], env=env, stderr=follower, stdout=subprocess.DEVNULL)
    os.close(follower)
    out = b""
    while True:
        try:
            chunk = os.read(leader, 4096)
        except OSError:  # the child closed the terminal
            break
        if not chunk:
            break
        out += chunk
    assert proc.wait(timeout=600) == 0, out
    os.close(leader)
    return out.decode(errors="replace")


@pytest.mark.slow
def test_a_cold_cache_says_it_once_and_a_warm_one_nothing(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "ROBOCAL_KERNELS": "numba"}
    assert MESSAGE in run_on_a_terminal(env)  # an empty cache: the kernels compile
    assert MESSAGE not in run_on_a_terminal(env)  # they load from the cache
    elsewhere = {**env, "NUMBA_CACHE_DIR": str(tmp_path / "other")}
    quiet = subprocess.run([sys.executable, "-c", FK], env=elsewhere, capture_output=True, text=True,
                           check=True, timeout=600)
    assert MESSAGE not in quiet.stderr  # compiled, but not on a terminal
