"""Loaders for the two public real laser-tracker data sets (read from where they lie; never
copied): Meca500 (FARO, 490 calibration / 70 validation poses) and ABB IRB 120 (FARO, 1000
poses x 3 SMRs, split 500 / 500). See shared/datasets/README.md for their sources."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.data.importer import import_tracker


def _folder(root, name: str) -> Path:
    folder = Path(root) / name
    if not folder.is_dir():
        raise DataError(f"data set folder {folder} not found")
    return folder


def meca500(root):
    """(calibration, validation) Measurements of the Meca500 set in ``root``/meca500-faro."""
    folder = _folder(root, "meca500-faro")
    sets = []
    for prefix in ("cal", "val"):
        files = sorted(folder.glob(f"{prefix}_data__*_Output.csv"))
        sets.append(import_tracker(files, joints="cols=0-5:deg", points="cols=6-8:m").data)
    return tuple(sets)


def irb120(root, n_calibration: int = 500):
    """(first ``n_calibration`` poses, the rest) of the IRB 120 set, 3 SMRs per pose."""
    folder = _folder(root, "irb120-faro")
    data = import_tracker(joints=f"{folder / 'measured_joints.txt'}:cols=0-5:deg",
                          points=[f"{folder / f'measured_SMR_{k}.txt'}:mm" for k in (1, 2, 3)]).data
    first = data.pose_id < n_calibration
    return data.subset(np.flatnonzero(first)), data.subset(np.flatnonzero(~first))
