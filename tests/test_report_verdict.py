"""The report's verdict box: the level and next step each rule gives, the noise floor and the
parameters held at nominal counted with the warnings (never 'No warnings.' while one is held)."""

from __future__ import annotations

import pytest

from robocal.report.verdict import FLOOR_FACTOR, held_parameters, next_step, noise_floor_mm, verdict_box


def result(**fields) -> dict:
    base = {"converged": True, "validation": {"rms": 0.036, "n": 100},
            "consistency": {"verdict": "consistent", "noise_mm": 0.02},
            "predicted_accuracy": {"workspace": {"rms": 0.04, "p95": 0.07}, "holds_only_near_poses": False},
            "warnings": [], "dropped": []}
    return {**base, **fields}


@pytest.mark.parametrize("fields, level, words", [
    ({}, "good", "Ready to use"),
    ({"converged": False}, "bad", "did not converge"),
    ({"consistency": {"verdict": "inconsistent", "noise_mm": 0.02}}, "bad", "misses its own data"),
    ({"consistency": {"verdict": "step", "noise_mm": 0.02}}, "bad", "measuring order"),
    ({"validation": None}, "care", "No poses were held out"),
    ({"predicted_accuracy": {"workspace": {"rms": 3.0}, "holds_only_near_poses": True}}, "care",
     "holds only near its poses"),
    ({"validation": {"rms": 0.2, "n": 50}}, "care", "noise floor"),
])
def test_next_step_rules(fields, level, words):
    got_level, sentence = next_step(result(**fields))
    assert got_level == level and words in sentence


def test_noise_floor_and_held_parameters_in_the_box():
    r = result(dropped=[{"name": "theta1", "reason": "not identifiable"}, {"name": "d6", "reason": "held"}])
    assert noise_floor_mm(r) == pytest.approx(0.02 * 3**0.5)
    assert held_parameters(r) == ["theta1", "d6"]
    box = verdict_box(r)
    assert "1 parameter(s) not identifiable (held at nominal, the confounders absorb it): theta1" in box
    assert "1 parameter(s) held at nominal: d6" in box and "No warnings" not in box
    assert "0.0346 mm" in box  # the noise floor, sqrt(3) x 0.02 mm
    assert FLOOR_FACTOR * 0.0346 > 0.036


def test_user_strings_are_escaped():
    box = verdict_box(result(dropped=[{"name": "<script>x</script>"}]))
    assert "<script>" not in box and "&lt;script&gt;" in box
