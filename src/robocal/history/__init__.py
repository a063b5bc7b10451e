"""A robot's history: calibrations and checks recorded in a database (`robocal.history.store`),
the check of a calibration against a short campaign (`robocal.history.check`), offsets-only
recalibration (`robocal.history.offsets`)."""

from robocal.history.store import History, Record

__all__ = ["History", "Record"]
