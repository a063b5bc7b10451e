"""A SCARA whose axes are a little off parallel (a calibrated model, a file with rounded angles)
keeps a SCARA's structure: the registration's degeneracy check counts the freedom its structure
leaves (the SMR height beside the frame's), judged within FIXED_AXIS_RAD, not as a 6-axis arm's.
It said "the pose set is degenerate" at 1 microradian before."""

from __future__ import annotations

import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.core.errors import IdentificationError
from robocal.data.registration import FIXED_AXIS_RAD, register_frame, turns_about_one_axis
from robocal.data.simulate import simulate_tracker

TILTED = ("alpha2", "beta2", "alpha3", "beta3")


def _tilted(tilt: float) -> rc.Robot:
    """The Epson G6 with axes 2 and 3 tilted by ``tilt`` rad (alpha and beta)."""
    nominal = rc.Robot.from_catalog("epson_g6_651s")
    return nominal.with_values(dict.fromkeys(TILTED, tilt))


@pytest.mark.parametrize("tilt", [1e-7, 1e-6, 3e-6, 1e-5])
def test_a_nearly_parallel_scara_registers_and_calibrates(tilt):
    robot = _tilted(tilt)
    assert turns_about_one_axis(robot)
    sim = simulate_tracker(robot, 40, seed=2, noise_mm=0.0)
    reg = register_frame(robot, sim.data)  # 1e-6 rad: "the pose set is degenerate" before
    assert reg.rms < 3e-3  # m: the nominal model against its perturbed truth
    result = rc.calibrate(robot, sim.data, nongeometric="none")  # 3e-6 rad: theta2 "corrected" 7 deg before
    q = np.random.default_rng(9).uniform(robot.limits[:, 0], robot.limits[:, 1], (200, 4))
    held_out = result.robot.fk(q)[:, :3, 3] - sim.truth.fk(q)[:, :3, 3]
    assert np.abs(held_out).max() < 1e-7  # m: the truth's TCP everywhere (noise-free data)
    # the structure's freedoms held and named as an exact SCARA's: no link length "undetermined" in
    # place of the SMR height (a2 or a3 was, at 1e-7 and 1e-6 rad)
    ident = result.identifiability
    assert not [n for n in ident.undetermined if n[0] in "ad" and n[1:].isdigit()], ident.undetermined
    assert {"height", "turn", "tilt", "axis1", "quill", "forearm"} <= {f["freedom"] for f in ident.freedoms}


def test_the_wobble_bound_separates_scaras_from_arms():
    """Truth by construction: a SCARA tilted well beyond FIXED_AXIS_RAD is no longer one, a 6-axis
    arm never is; a really degenerate SCARA pose set (one pose repeated) is still refused."""
    assert not turns_about_one_axis(_tilted(30 * FIXED_AXIS_RAD))
    assert not turns_about_one_axis(rc.Robot.from_catalog("abb_irb2600"))
    robot = _tilted(1e-6)
    q = np.tile(np.deg2rad([[20.0, 40.0, 0.0, 10.0]]), (12, 1))
    q[:, 2] = -0.05
    sim = simulate_tracker(robot, joints=q, seed=1, noise_mm=0.0)
    with pytest.raises(IdentificationError, match="degenerate"):
        register_frame(robot, sim.data)


def test_cli_calibrates_a_nearly_parallel_scara(tmp_path, capsys):
    robot = _tilted(1e-6)
    robot.save(tmp_path / "g6.yaml")
    sim = simulate_tracker(robot, 40, seed=2, noise_mm=0.01)
    sim.data.save(tmp_path / "points.csv")
    code = main(["calibrate", str(tmp_path / "points.csv"), "--robot", str(tmp_path / "g6.yaml"),
                 "--nongeometric", "none", "-o", str(tmp_path / "cal.yaml")])
    err = capsys.readouterr().err
    assert code == 0 and "degenerate" not in err, err
