"""Calibration: the pipeline from measurements to a calibrated model, its result, the choice of the
error model, the conditions covered, evaluation on other data."""
