"""Shared by the run-time correction tests (tests/test_runtime_*.py): the 'true' robot and its
calibrated model, and the tolerances the executed routine is held to."""

from __future__ import annotations

from robocal.data.simulate import perturbed

MODEL_ERROR_FACTOR = 1.3  # the goal: the routine lands within 1.3x the calibrated model's own error
ROUTINE_SLACK_MM = 0.002  # the routine stops within 1 um (TOLERANCE_MM) of the calibrated model's answer
SAME_AS_OFFLINE_MM = 0.005  # routine vs offline compensate (RAPID's float32 nums included)


def calibrated_from(true, seed: int):
    """A calibrated model of ``true`` with its own error: 0.01-0.04 mm, 0.0005-0.002 deg."""
    return perturbed(true, seed, length_mm=(0.01, 0.04), angle_deg=(0.0005, 0.002))


def true_and_calibrated(nominal):
    """The 'true' robot (``nominal`` off by 0.2-0.8 mm, 0.02-0.08 deg; seed 3) and its calibrated
    model (seed 4)."""
    true = perturbed(nominal, 3, length_mm=(0.2, 0.8), angle_deg=(0.02, 0.08))
    return true, calibrated_from(true, 4)
