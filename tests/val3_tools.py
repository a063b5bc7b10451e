"""Shared by the VAL3 tests: an application filtered, written, and executed before and after."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.programs import filter_program
from robocal.programs.dialects.val3.reader import application_files
from robocal.programs.simulate import execute


def reached_before_after(folder: Path, out: Path, calibrated, nominal
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Filter the application in ``folder`` (``calibrated`` against ``nominal``), write its outputs
    to the new folder ``out``, and execute both on ``calibrated``: (the filtered application's
    reached poses, the original's, the poses the original meant), each (n, 4, 4) in m."""
    res = filter_program([folder], calibrated, nominal)
    out.mkdir()
    for p, data in res.outputs.items():
        (out / p.name).write_bytes(data)
    reached, _ = execute(application_files(out), calibrated, nominal)
    before, X0 = execute(application_files(folder), calibrated, nominal)
    return reached, before, X0
