"""Knowing the limits of an answer: residuals against the instrument (:mod:`.consistency`),
predicted accuracy over the workspace (:mod:`.coverage`) and data fingerprints (:mod:`.provenance`).

A layer above :mod:`robocal.identify` and below :mod:`robocal.calibration`: every command asks it,
none re-implements it.
"""
