"""Shared fixtures: each test once per kernel implementation, a seeded random generator.
Helpers the tests import by name (random robots, frames, the data sets folder) are in robots.py;
waits on child processes go through children.py (each with a deadline). A test that opens a
browser or takes more than a few seconds is marked ``@pytest.mark.slow``: `make test` leaves it
to `make test-slow` (CI runs both)."""

from __future__ import annotations

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
