"""Measurement inputs as a command is given them: each file once, read with what the reader
noticed (repeated readings grouped, conditions the model has no term for)."""

from __future__ import annotations

import hashlib
from pathlib import Path

from robocal.core.errors import DataError
from robocal.data.joint_conventions import fanuc_decoupled_data
from robocal.data.measurements import Measurements

TWICE = "each reading would count twice (the noise estimate shrinks, the result looks better than it is)"


def check_distinct_inputs(paths, what: str = "input files", why: str = TWICE) -> None:
    """Refuse a file given twice (the same path, or two files with identical contents): each of
    its readings would count twice, the noise estimate shrink by sqrt 2 and the judgement lie.

    Parameters
    ----------
    paths : iterable of str or Path or None
        The input files (None entries and missing files are skipped: the reader names those).
    what : str
        What the files are, for the message (``"calibration files"``).
    why : str
        Why a file given twice is wrong here.

    Raises
    ------
    DataError
        Two of ``paths`` are the same file or have the same contents.

    See Also
    --------
    rc.calibrate : Refuses the same file given as two roles.
    robocal.deploy.models.load_model_pair : The calibrated and nominal models of a deployment, checked.

    Examples
    --------
    >>> from pathlib import Path
    >>> from robocal.data.inputs import check_distinct_inputs
    >>> for name in ("cal.csv", "copy.csv"):
    ...     _ = Path(name).write_text("pose_id,q1_deg\\n0,1.0\\n")
    >>> check_distinct_inputs(["cal.csv", "val.csv"])  # a missing file: the reader names it
    >>> check_distinct_inputs(["cal.csv", "copy.csv"], "calibration files")
    Traceback (most recent call last):
    ...
    robocal.core.errors.DataError: copy.csv has the same contents as cal.csv among the calibration files: ...
    """
    seen: dict = {}
    for path in (p for p in paths if p is not None):
        p = Path(path)
        if not p.is_file():
            continue  # the reader names a missing file
        key = hashlib.sha256(p.read_bytes()).hexdigest()
        if key in seen:
            same = "is given twice" if p.resolve() == Path(seen[key]).resolve() else \
                f"has the same contents as {seen[key]}"
            raise DataError(f"{path} {same} among the {what}: {why}; give each file once")
        seen[key] = path


def read_measurements(path, robot, fanuc_coupled: bool = False,
                      model_used: bool = True) -> tuple[Measurements, list[str]]:
    """`Measurements.load` of ``path`` checked against ``robot``, with the reader's notes.

    Parameters
    ----------
    path : str or Path
        A canonical measurement CSV.
    robot : Robot
        The model the data are read for.
    fanuc_coupled : bool
        The joints are a FANUC controller's (J3 from the horizontal): converted to the catalog's.
    model_used : bool
        ``robot`` is the model the command applies: the notes then also name the recorded
        conditions it has no term for.

    Returns
    -------
    tuple
        (the measurements, their notes: one line each, warnings starting with ``WARNING``).
    """
    data = Measurements.load(path, robot=robot)
    if fanuc_coupled:
        data = fanuc_decoupled_data(data)
    used = [data.unused_conditions(robot), *data.missing_conditions(robot)] if model_used else []
    return data, [note for note in (*data.notes, *used) if note]
