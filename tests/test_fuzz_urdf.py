"""Random serial URDF chains with revolute and prismatic joints (tests/fuzz_urdf.py): a valid
one imports (API and ``robocal export X.urdf --yaml``) with the FK of an independent composition
of its joints; a broken one is refused in one line with nothing written. The default run is a
seeded sample; the slow one, and ``python tests/fuzz_urdf.py 3000``, the full round."""

from __future__ import annotations

import random

import numpy as np
import pytest
from fuzz_urdf import Joint, cli, fuzz_one, one_error_line, to_urdf

FAST = 150
SLOW = 3000


def test_random_chains_keep_the_contract(tmp_path):
    rng = random.Random(0)
    problems = [p for k in range(FAST) for p in fuzz_one(rng, tmp_path, k % 10 == 0)]
    assert not problems, "\n".join(problems[:3])


@pytest.mark.slow
def test_many_random_chains_keep_the_contract(tmp_path):
    rng = random.Random(1)
    problems = [p for k in range(SLOW) for p in fuzz_one(rng, tmp_path, k % 10 == 0)]
    assert not problems, "\n".join(problems[:3])


def test_a_urdf_whose_model_no_model_file_holds_is_refused_not_written(tmp_path):
    """A gantry of three 30 m slides (each origin within the URDF bounds): the API builds it, but
    its reach is beyond what a model file holds, and ``export --yaml`` wrote a file exit 0 that
    ``Robot.load`` then refused."""
    z = np.zeros(3)
    joints = [Joint(f"j{k}", "prismatic", np.eye(3)[k] * 30.0, z, np.eye(3)[k], 0.0, 1.0) for k in range(3)]
    src, out = tmp_path / "gantry.urdf", tmp_path / "gantry.yaml"
    src.write_text(to_urdf(joints))
    code, err = cli(["export", str(src), "--yaml", str(out)])
    assert one_error_line(code, err) and "would not read back" in err and not out.exists()
