"""A robot's history: calibrations and checks recorded in a database (:mod:`.store`), the check of
a calibration against a short campaign (:mod:`.check`), offsets-only recalibration (:mod:`.offsets`)."""

from robocal.history.store import History, Record

__all__ = ["History", "Record"]
