"""Issue 45's goals on a hidden cell truth with its own kinematics, controller and tracker
(benchmarks/hidden_cell.py, small version): robocal driven through its command line only.

Each check's truth is the benchmark's, not robocal's: the arm and positioner as products of
exponentials of perturbed axis lines, the controller's numeric IK, the tracker's noise; the files
are read and diffed by the benchmark's own parsers."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import hidden_cell as hc  # noqa: E402

pytestmark = pytest.mark.slow  # four cell calibrations and six filter runs per variant (about 40 s each)


def _matches_model(r: dict) -> bool:
    """Filtered targets land where the calibrated cell itself says (1.3x its own error + 2 um)."""
    return r["filtered_mm"] <= hc.LAND_FACTOR * r["own_mm"] + hc.LAND_MARGIN_MM


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    return hc.run(0, hc.SMALL, tmp_path_factory.mktemp("hidden"))


def test_truth_has_the_controllers_joint_conventions(report):
    assert all(v < 1e-12 for v in report["conventions_m"].values())


@pytest.mark.parametrize("variant", list(hc.VARIANTS))
def test_held_out_rms_at_the_noise_floor(report, variant):
    for arm in ("abb_calibration", "kuka_calibration"):
        for mode in ("nests", "free"):
            assert report[variant][arm][mode]["ratio"] <= hc.HELDOUT_FACTOR, (variant, arm, mode)


@pytest.mark.parametrize("variant", list(hc.VARIANTS))
def test_filtered_targets_land_where_the_calibrated_cell_says(report, variant):
    """Every program, nests or not, flange on its axis or not: the filter is as good as its model;
    only the numbers of the poses change; positioner values and configuration data stay."""
    r = report[variant]
    programs = [*(r["rapid"][m][s] for m in ("nests", "free") for s in r["rapid"][m]), r["krl"]]
    for p in programs:
        assert "error" not in p, p
        assert _matches_model(p), p
        assert p["outside_numbers_changed"] == [] and p["eax_kept"] and p["config_mismatched"] == 0
    for m in ("nests", "free"):
        for style in r["rapid"][m].values():
            u = style["uncoordinated"]
            assert _matches_model(u) and u["filtered_mm"] < u["unfiltered_mm"], u
    assert r["unknown_unit"]["goal_met"], r["unknown_unit"]


def test_goal_met_with_nests_and_the_flange_on_its_axis(report):
    """With nests the plate frame is identified, and with the flange where its axis carries it the
    tool is where the model says: filtered targets >= 10x better than unfiltered (issue 45's goal).
    Without nests (the turn axis' zero held) or with a flange off its axis (SMRs at unknown places
    cannot see it) the model's own error stays, as robocal says: asserted by the test above."""
    r = report["flange on its axis"]
    for p in [*r["rapid"]["nests"].values(), r["krl"]]:
        assert p["goal_met"], p
