"""Issue 46's run-time correction goal on hidden truths with their own kinematics and controller
(benchmarks/hidden_runtime.py, small version): ``robocal filter --runtime-correction`` through
its command line; the routed motions land on the true arm within 1.3x the calibrated model's own
error (+ 2 um), better than unfiltered, and every byte outside the routine and the wrapped
arguments is what the filter writes without the option."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import hidden_runtime as hr  # noqa: E402

pytestmark = pytest.mark.slow  # six calibrations and 24 filter runs (about 100 s)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    return hr.run(0, hr.SMALL, tmp_path_factory.mktemp("hidden_runtime"))


def test_truth_has_the_controllers_joint_conventions(report):
    assert all(v < 1e-12 for v in report["conventions_m"].values())


def _cases(report):
    return {k: v for k, v in report.items() if k != "conventions_m"}


def test_every_language_routes_its_run_time_motions(report):
    cases = _cases(report)
    assert len(cases) == 12
    assert all("error" not in r and r["routed_motions"] >= 4 for r in cases.values())


def test_routed_motions_land_within_the_goal(report):
    """Not always better than unfiltered: with the true base plate as the world or the flange off
    its axis, the model's own error (what an arm-only tracker calibration cannot see) may exceed
    the true arm's error from the nominal on these targets."""
    for case, r in _cases(report).items():
        assert r["goal_met"], (case, r["worst"])
        assert r["ik_calls_max"] <= 3, case
        assert r["config_mismatched"] == 0, case  # the emulated IK kept the configuration the target names


def test_with_the_calibrated_base_the_routine_corrects_to_the_calibration(report):
    """The world the calibration calls the robot's base and a flange SMRs identify: the model's
    own error is micrometres, and the routine lands there too (>= 20x better than unfiltered)."""
    for lang in ("RAPID", "KRL", "URScript"):
        r = report[f"{lang}, flange on its axis, world: calibrated frame {{0}}"]
        assert r["own_median_mm"] < 0.05 and r["unfiltered_median_mm"] > 20 * r["landing_median_mm"], lang


def test_every_other_byte_unchanged(report):
    assert all(r["unchanged"] for r in _cases(report).values())


def test_the_check_catches_a_wrong_routine(tmp_path):
    """The control: the same check on a routine whose calibrated d4 is 0.05 mm off misses."""
    r = hr.control(0, hr.SMALL, tmp_path)
    assert not r["goal_met"] and r["ratio_max"] > 2
