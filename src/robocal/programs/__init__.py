"""Robot programs: read ABB RAPID, KUKA KRL, FANUC TP (.ls), URScript and Yaskawa INFORM, and filter
their Cartesian targets through a calibrated model (see :mod:`robocal.programs.filter`)."""

from robocal.programs.filter import FilterResult, dialect_for, filter_program

__all__ = ["FilterResult", "dialect_for", "filter_program"]
