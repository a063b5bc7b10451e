"""Memory: a calibration that cannot fit is refused before it starts with one line saying what is
needed and what to do, and a MemoryError anywhere ends as that kind of line (never an internal error)."""

from __future__ import annotations

import numpy as np
import pytest

import robocal as rc
import robocal.core.resources as res
from robocal.calibration.pipeline import calibrate
from robocal.cli import main
from robocal.core.errors import ResourceError
from robocal.data.simulate import simulate_tracker


def test_the_estimate_grows_linearly_and_the_default_search_costs_more():
    assert res.calibration_bytes(0, True) == res.FIXED_BYTES
    per_pose = res.calibration_bytes(2000, True) - res.calibration_bytes(1000, True)
    assert per_pose == 1000 * res.BYTES_PER_POSE > 1000 * res.GEOMETRIC_BYTES_PER_POSE
    have = res.available_bytes()
    assert have is None or have > 0


def test_a_calibration_that_cannot_fit_is_refused_before_it_starts(monkeypatch):
    data = simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 30, seed=1).data
    monkeypatch.setattr(res, "available_bytes", lambda: 200_000_000)
    with pytest.raises(ResourceError, match=r"needs about 0\.30 GB.*offers 0\.20 GB.*--nongeometric none"):
        calibrate(rc.Robot.from_catalog("abb_irb2600"), data, nongeometric=None)
    monkeypatch.setattr(res, "available_bytes", lambda: None)  # unknown: it runs
    assert calibrate(rc.Robot.from_catalog("abb_irb2600"), data, nongeometric=None).robot is not None


def test_running_out_of_memory_is_one_clean_line(monkeypatch, tmp_path, capsys):
    data = simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 30, seed=1).data
    data.save(tmp_path / "d.csv")

    def exhausted(*args, **kwargs):
        np.empty(1)  # a real call site: any allocation inside the calibration
        raise MemoryError

    monkeypatch.setattr("robocal.calibration.pipeline._start_model", exhausted)
    with pytest.raises(ResourceError, match="the calibration ran out of memory: calibrate fewer poses"):
        calibrate(rc.Robot.from_catalog("abb_irb2600"), data, nongeometric=None)
    code = main(["--quiet", "calibrate", str(tmp_path / "d.csv"), "--robot", "abb_irb2600",
                 "-o", str(tmp_path / "c.yaml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "internal error" not in err[0] and "ran out of memory" in err[0]
    assert not (tmp_path / "c.yaml").exists()


def test_a_memory_error_outside_the_calibration_is_the_same_line(monkeypatch, capsys):
    def exhausted(args):
        raise MemoryError

    import robocal.cli as cli

    parser = cli.build_parser
    def patched():
        p = parser()
        for action in p._subparsers._group_actions:
            action.choices["robots"].set_defaults(func=exhausted)
        return p

    monkeypatch.setattr(cli, "build_parser", patched)
    assert main(["robots"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"robocal robots: error: {res.out_of_memory('the command', 'robots')}"]


def test_small_calibrations_run_on_one_blas_thread_and_large_ones_keep_theirs(monkeypatch):
    threadpoolctl = pytest.importorskip("threadpoolctl")
    import robocal.identify.lsq as lsq

    seen = []
    real = lsq.minimize

    def spy(*args, **kwargs):  # the damped loop, inside calibrate and gauss_newton
        seen.append(max(info["num_threads"] for info in threadpoolctl.threadpool_info()
                        if info["user_api"] == "blas"))
        return real(*args, **kwargs)

    monkeypatch.setattr(lsq, "minimize", spy)
    robot = rc.Robot.from_catalog("abb_irb2600")
    data = simulate_tracker(robot, 30, seed=1).data
    with threadpoolctl.threadpool_limits(2, user_api="blas"):
        calibrate(robot, data, nongeometric=None)
        assert seen and set(seen) == {1}
        monkeypatch.setattr(res, "SMALL_PROBLEM_ROWS", 10)  # now 30 poses are a large problem
        seen.clear()
        calibrate(robot, data, nongeometric=None)
        assert set(seen) == {2}
    # and the decorator returns what the function returns, either way
    for rows in (1, 10**9):
        assert res.few_threads(lambda n: n)(lambda n: n + 1)(rows) == rows + 1
