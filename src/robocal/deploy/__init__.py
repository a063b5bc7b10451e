"""Deploying a calibration: compensated targets and joints, a real tool's TCP, the models the
robot's programs are corrected with."""
