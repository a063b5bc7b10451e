"""Helpers the tests share: random robots with beta and arbitrary frames, angle wrapping, both
kernel implementations, and the shared folder of real data sets (skipping where it is absent).

Fixtures and hooks stay in conftest.py; everything a test imports by name lives here.
"""

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
    """A random 4x4 homogeneous transform: rotation up to 100 deg per axis, translation in +-scale."""
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


def require_datasets() -> Path:
    """The shared folder of real data sets; skips the calling test where it is absent."""
    if not DATASETS.is_dir():
        pytest.skip(f"real data sets not found at {DATASETS} (../shared/datasets is absent)")
    return DATASETS
