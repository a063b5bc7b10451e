"""Vendors' own kinematic calibration formats, read into and written from robocal models (one
module per vendor: :mod:`robocal.kinematics.manufacturer.ur`)."""
