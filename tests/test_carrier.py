"""Does an external axis carry the arm (robocal.programs.carrier)? Each verdict against a truth built
independently: positions made from a known track direction, slopes from numpy's own line fit."""

from __future__ import annotations

import re

import numpy as np
import pytest

from robocal.programs.carrier import (
    ANGLE_MAX_DEG,
    FOLLOW_SLOPE,
    MIN_DISTINCT,
    MIN_TARGETS,
    arm_carriers,
    follows,
)
from robocal.programs.registry import dialect_named


def _track(n: int, direction, seed: int = 0, reach_mm: float = 50.0):
    """``n`` targets of an arm on a track along unit ``direction``: values (mm), positions (mm) =
    the arm's place on the track plus its own reach (uniform, +-``reach_mm``)."""
    rng = np.random.default_rng(seed)
    e = np.sort(rng.uniform(0, 6000, n))
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    return e, np.array([1500.0, -300.0, 900.0]) + e[:, None] * d + rng.uniform(-reach_mm, reach_mm, (n, 3))


def test_follows_matches_numpys_line_fit():
    """The slope vector is each coordinate's least-squares slope (np.polyfit, an independent fit) and
    the correlation along its direction is numpy's corrcoef of the projected positions."""
    rng = np.random.default_rng(1)
    e = rng.uniform(-500, 500, 30)
    X = rng.normal(size=(30, 3)) * 100 + e[:, None] * np.array([0.3, -0.8, 0.1])
    slope, r, u = follows(e, X)
    b = np.array([np.polyfit(e, X[:, k], 1)[0] for k in range(3)])
    assert slope == pytest.approx(np.linalg.norm(b), rel=1e-12)
    np.testing.assert_allclose(u, b / np.linalg.norm(b), atol=1e-12)
    assert r == pytest.approx(np.corrcoef(e, X @ u)[0, 1], rel=1e-12)
    assert follows(e, np.zeros((30, 3)))[:2] == (0.0, 0.0)  # positions that do not move


@pytest.mark.parametrize("direction", [(1, 0, 0), (0, -1, 0), (0.6, 0.8, 0)])
def test_a_track_is_found_along_its_direction(direction):
    """Targets of an arm on a track, any direction: the axis carries the arm, the reason giving a
    slope of 1.00 mm per mm along the track's direction (the truth it was built with)."""
    e, X = _track(12, direction)
    why = arm_carriers({"eax_a": e}, X)["eax_a"]
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    m = re.search(r"carries the arm .* ([\d.]+) mm per mm along \(([-\d., ]+)\), correlation ([\d.]+)", why)
    assert float(m.group(1)) == pytest.approx(1.0, abs=0.015) and float(m.group(3)) >= 0.99
    np.testing.assert_allclose([float(c) for c in m.group(2).split(",")], d, atol=0.015)  # +-50 mm reach


def test_positioner_constant_linear_and_few():
    """A positioner's angles under targets that do not follow them: no verdict (an arm target); an
    axis held at one value: no evidence; a linear axis (beyond any turn) the targets do not follow:
    may carry the arm; an axis that varies over too few targets or values: may carry the arm."""
    rng = np.random.default_rng(2)
    X = rng.uniform(-400, 400, (10, 3)) + [1200, 0, 900]
    angles = np.linspace(-90, 90, 10)
    rng.shuffle(angles)
    assert follows(angles, X)[1] < 0.9  # the truth of this data set: no line
    assert arm_carriers({"eax_b": angles}, X) == {}
    assert arm_carriers({"eax_a": np.full(10, 1500.0)}, X) == {}
    linear = angles * 10 + 1000  # 100 .. 1900 mm
    assert "beyond any positioner turn" in arm_carriers({"eax_a": linear}, X)["eax_a"]
    assert np.abs(linear).max() > ANGLE_MAX_DEG
    few = arm_carriers({"eax_a": angles[:MIN_TARGETS - 1]}, X[:MIN_TARGETS - 1])["eax_a"]
    assert "too few to tell" in few
    two = np.repeat(angles[:MIN_DISTINCT - 1], 5)
    assert "too few to tell" in arm_carriers({"eax_a": two}, X)["eax_a"]


def test_slope_outside_the_band_is_no_track():
    """Targets moving 3 mm per unit of the axis (a positioner's angle can't carry the arm that way;
    no track moves the arm 3 mm per mm): not a track; within a turn, no verdict."""
    e = np.linspace(-60, 60, 8)
    X = np.array([1200.0, 0, 900]) + e[:, None] * [3.0, 0, 0]
    assert follows(e, X)[0] > FOLLOW_SLOPE[1]
    assert arm_carriers({"eax_b": e}, X) == {}


def test_targets_in_unknown_frames_are_no_evidence():
    """NaN positions (a frame not known yet) and NaN values (a target without the axis) are left out."""
    e, X = _track(12, (1, 0, 0))
    X[:9] = np.nan
    assert "too few to tell" in arm_carriers({"eax_a": e}, X)["eax_a"]
    e2 = e.copy()
    e2[:2] = np.nan
    assert "carries the arm" in arm_carriers({"eax_a": e2}, _track(12, (1, 0, 0))[1])["eax_a"]


def test_each_dialect_names_the_axes_that_may_carry_the_arm():
    """RAPID's eax_a..f and KRL's E1..E6 may be a track or gantry; a FANUC group's axes and an INFORM
    station's cannot (their arm-carrying axes are named by their readers)."""
    assert dialect_named("rapid").arm_axes[:2] == ("eax_a", "eax_b")
    assert dialect_named("krl").arm_axes[:2] == ("E1", "E2")
    assert dialect_named("fanuc").arm_axes == () and dialect_named("inform").arm_axes == ()
