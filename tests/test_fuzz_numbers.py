"""Extreme numbers in the numeric options (nan, inf, 1e308, a negative seed): a one-line refusal,
never an internal error. The options found to end in exit 3 by a sweep of every numeric option of
calibrate, evaluate, compensate, simulate and poses (nan, inf, -inf, 1e308, -1, 0, 1e9)."""

from __future__ import annotations

import pytest
from fuzz_urdf import cli, one_error_line

import robocal as rc
from robocal.core.errors import DataError

BASE = ["poses", "--robot", "abb_irb2600", "-n", "12", "--candidates", "200", "--starts", "1"]


@pytest.mark.parametrize("option, value", [("--seed", "-1"), ("--noise-mm", "inf"), ("--noise-mm", "1e308"),
                                           ("--noise-mm", "nan"), ("--unmodelled-mm", "1e308"),
                                           ("--min-joint-distance-deg", "1e308")])
def test_poses_refuses_extreme_numbers_in_one_line(tmp_path, option, value):
    out = tmp_path / "p.csv"
    code, err = cli([*BASE, "-o", str(out), option, value])
    assert one_error_line(code, err) and not out.exists(), err


def test_the_planner_checks_its_numbers_through_the_api():
    robot = rc.Robot.from_catalog("abb_irb2600")
    for kw in ({"noise_mm": float("inf")}, {"seed": -1}, {"unmodelled_mm": float("nan")}):
        with pytest.raises(DataError):
            rc.plan_poses(robot, 12, n_candidates=200, starts=1, **kw)


def test_a_command_out_of_memory_gets_its_own_advice(tmp_path, monkeypatch):
    """``poses --candidates 100000000`` ran out of memory and was told to 'calibrate fewer poses, use
    --nongeometric none'."""
    import robocal.campaign as campaign

    def exhausted(*args, **kwargs):
        raise MemoryError
    monkeypatch.setattr(campaign, "plan_poses", exhausted)
    code, err = cli([*BASE, "-o", str(tmp_path / "p.csv")])
    assert one_error_line(code, err) and "ran out of memory" in err and "nongeometric" not in err, err
