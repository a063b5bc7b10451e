"""One noise floor (robocal.report.floor): its formula against Monte Carlo draws of the noise, the
model's own error against a simulated model error, and the same figure in a calibration's
summary(), its to_dict() and the report's first screen (the summary section), which shows no other
noise floor; the warning count coloured by what it says."""

from __future__ import annotations

import re

import numpy as np
import pytest

import robocal as rc
from robocal.report.floor import noise_floor_mm, of_result, own_error_mm
from robocal.report.format import num

DRAWS = 200_000  # noise vectors per Monte Carlo check: the RMS is within ~0.3 % of its expectation
MC_RTOL = 0.01


def test_floor_is_the_expected_rms_of_the_noise():
    rng = np.random.default_rng(1)
    for sigma in (0.005, 0.02, 0.1):
        noise = rng.normal(0.0, sigma, (DRAWS, 3))
        drawn = float(np.sqrt(np.mean(np.sum(noise**2, axis=1))))
        assert noise_floor_mm(sigma) == pytest.approx(drawn, rel=MC_RTOL)
    # items of two instruments: the RMS over all of them
    s = np.where(np.arange(DRAWS) % 4 == 0, 0.05, 0.01)
    noise = rng.normal(0.0, 1.0, (DRAWS, 3)) * s[:, None]
    assert noise_floor_mm(s) == pytest.approx(np.sqrt(np.mean(np.sum(noise**2, axis=1))), rel=MC_RTOL)
    plane = rng.normal(0.0, 0.01, DRAWS)  # 1-D items (distances to a plane)
    assert noise_floor_mm(0.01, dimensions=1) == pytest.approx(np.sqrt(np.mean(plane**2)), rel=MC_RTOL)
    with pytest.raises(ValueError):
        noise_floor_mm(-0.01)


def test_own_error_recovers_the_models_error():
    rng = np.random.default_rng(2)
    model = rng.normal(0.0, 0.03, (DRAWS, 3))  # the model's own error, independent of the noise
    noise = rng.normal(0.0, 0.02, (DRAWS, 3))
    rms = float(np.sqrt(np.mean(np.sum((model + noise) ** 2, axis=1))))
    own = float(np.sqrt(np.mean(np.sum(model**2, axis=1))))
    assert own_error_mm(rms, noise_floor_mm(0.02)) == pytest.approx(own, rel=MC_RTOL)
    assert own_error_mm(0.01, 0.02) == 0.0


def test_an_older_result_falls_back_to_the_calibration_noise():
    assert of_result({"consistency": {"noise_mm": 0.02}}) == pytest.approx(0.02 * 3**0.5)
    assert of_result({"validation": {"rms": 0.04, "noise_floor_mm": 0.05},
                      "consistency": {"noise_mm": 0.02}}) == 0.05
    assert of_result({}) is None


@pytest.fixture(scope="module")
def calibrated():
    pytest.importorskip("matplotlib", reason="the report needs the report extra")
    robot = rc.Robot.from_catalog("abb_irb2600")
    cal = rc.simulate_tracker(robot, 30, seed=3)
    val = rc.simulate_tracker(cal.truth, 60, seed=4, as_is=True)
    return rc.calibrate(robot, cal.data, validation=val.data)


def test_summary_to_dict_and_report_show_one_floor(calibrated):
    from robocal.report.html import render_report

    floor = calibrated.noise_floor_mm
    assert floor == pytest.approx(noise_floor_mm(0.02))  # the tracker's documented 20 um per coordinate
    content = calibrated.to_dict()
    assert content["validation"]["noise_floor_mm"] == floor
    assert f"noise floor of {floor:.4f} mm" in calibrated.summary()
    page = render_report(content)
    first = page[:page.index("</section>")]  # the header and the summary section
    assert f"noise floor of {num(floor)} mm" in first
    assert len(re.findall(r"noise floor", first)) == 1, "one noise floor on the first screen"
    own = own_error_mm(content["validation"]["rms"], floor)
    assert f"own error is about {num(own)} mm" in first
    assert f"own error is about {own:.4f} mm" in calibrated.summary()


def test_the_warning_count_is_coloured_by_what_it_says(calibrated):
    from robocal.report.html import render_report

    content = calibrated.to_dict()
    quiet = render_report({**content, "warnings": []})
    assert "<b class='bad'>0 warning" not in quiet
    loud = render_report({**content, "warnings": ["something to read"]})
    assert "<b class='bad'>1 warning(s)</b>" in loud


def test_wide_tables_take_the_full_width(calibrated):
    """The parameter and error-model tables (8 columns) are not put in half-width columns, where
    they were clipped at 1280 px; a table in a column scrolls inside it."""
    from robocal.report.html import render_report

    page = render_report(calibrated.to_dict())
    assert '<section id="parameters">' in page
    assert page.count("<table") == page.count("<div class='scroll")  # each table in a scrolling box
