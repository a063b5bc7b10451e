"""Shared fixtures: random robots with beta and arbitrary frames, the shared data folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robocal import Robot
from robocal.kinematics.kernels import compiled, use_kernels
from robocal.kinematics.transforms import make_transform, rotvec_to_matrix

SHARED = Path(__file__).resolve().parents[2] / "shared"
DATASETS = SHARED / "datasets"


def random_frame(rng: np.random.Generator, scale: float = 1.0) -> np.ndarray:
    return make_transform(rotvec_to_matrix(rng.uniform(-np.pi / 1.8, np.pi / 1.8, 3)),
                          rng.uniform(-scale, scale, 3))


def wrapped(a: np.ndarray) -> np.ndarray:
    """Angles (rad) into [-pi, pi)."""
    return np.remainder(a + np.pi, 2 * np.pi) - np.pi


def random_robot(rng: np.random.Generator, n: int = 6) -> Robot:
    """A random MDH + beta robot with non-zero beta everywhere and arbitrary base/tool."""
    return Robot(alpha=rng.uniform(-np.pi, np.pi, n), a=rng.uniform(-0.5, 0.5, n),
                 beta=rng.uniform(-0.2, 0.2, n), theta=rng.uniform(-np.pi, np.pi, n),
                 d=rng.uniform(-0.5, 0.5, n), base=random_frame(rng, 2.0),
                 tool=random_frame(rng, 0.2), parallel=np.ones(n, bool), name="random")


def _numba_importable() -> bool:
    with use_kernels("auto"):
        return compiled("robocal.kinematics.fk_numba") is not None


requires_numba = pytest.mark.skipif(not _numba_importable(),
                                    reason="numba not installed (pip install '.[fast]')")
# both implementations of the hot kernels (robocal.kinematics.kernels); numba only with the extra
KERNELS = ["numpy", pytest.param("numba", marks=requires_numba)]


@pytest.fixture(params=KERNELS)
def kernels(request) -> str:
    """Runs the test once with the numpy kernels and once with the compiled ones."""
    with use_kernels(request.param):
        yield request.param


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


def require_datasets() -> Path:
    if not DATASETS.is_dir():
        pytest.skip(f"real data sets not found at {DATASETS} (../shared/datasets is absent)")
    return DATASETS
