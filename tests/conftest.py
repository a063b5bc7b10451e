"""Shared fixtures: each test once per kernel implementation, a seeded random generator, the
documentation site built once for the tests that read it.
Helpers the tests import by name (random robots, frames, the data sets folder) are in robots.py;
waits on child processes go through children.py (each with a deadline). A test that opens a
browser or takes more than a few seconds is marked ``@pytest.mark.slow``: `make test` leaves it
to `make test-slow` (CI runs both)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from robots import KERNELS

from robocal.kinematics.kernels import use_kernels


@pytest.fixture(params=KERNELS)
def kernels(request) -> str:
    """Runs the test once with the numpy kernels and once with the compiled ones."""
    with use_kernels(request.param):
        yield request.param


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def site(tmp_path_factory) -> Path:
    """The documentation site, built once (``mkdocs build --strict``) for every test that reads it
    (test_site, test_site_search); skipped without the docs extra."""
    pytest.importorskip("mkdocs", reason="the site needs the docs extra (pip install '.[docs]')")
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d", str(out)],
                          cwd=Path(__file__).resolve().parents[1], capture_output=True, text=True, env=env,
                          check=False, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out
