"""Robot programs: read ABB RAPID, KUKA KRL, FANUC TP (.ls), URScript, Yaskawa INFORM and Staubli
VAL3, and filter their Cartesian targets through a calibrated model (see `robocal.programs.filter`;
the languages: `robocal.programs.registry`). The names below are imported when first used, so that
the command line reads the registry's keys without importing every reader."""

from __future__ import annotations

import importlib

_HOMES = {"FilterResult": "robocal.programs.result", "dialect_for": "robocal.programs.registry",
          "filter_program": "robocal.programs.filter",
          "read_schedules": "robocal.programs.dialects.fanuc.loads"}
__all__ = ["FilterResult", "dialect_for", "filter_program", "read_schedules"]


def __getattr__(name: str):
    if name not in _HOMES:
        raise AttributeError(f"module 'robocal.programs' has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOMES[name]), name)
    globals()[name] = value
    return value
