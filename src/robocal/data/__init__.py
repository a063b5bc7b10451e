"""Measurements, their files and importer, the virtual laser tracker, and frame registration."""

from robocal.data.measurements import Measurements
from robocal.data.registration import Registration, register, register_frame
from robocal.data.simulate import SimulationResult, simulate_tracker, write_simulation

__all__ = ["Measurements", "Registration", "SimulationResult", "register", "register_frame",
           "simulate_tracker", "write_simulation"]
