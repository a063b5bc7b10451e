"""Robot programs: read ABB RAPID, KUKA KRL, FANUC TP (.ls), URScript, Yaskawa INFORM and Staubli
VAL3, and filter their Cartesian targets through a calibrated model (see `robocal.programs.filter`)."""

from robocal.programs.filter import FilterResult, dialect_for, filter_program
from robocal.programs.load_data import read_schedules

__all__ = ["FilterResult", "dialect_for", "filter_program", "read_schedules"]
