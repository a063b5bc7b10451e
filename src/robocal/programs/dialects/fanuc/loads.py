"""The load statements of FANUC TP programs (the reader interface: :mod:`robocal.programs.load_data`).

``PAYLOAD[n]`` selects payload schedule n of motion group 1, whose values live in the controller
(``$PLST_GRP1[n].$PAYLOAD`` kg, ``$PAYLOAD_X/_Y/_Z`` cm in the faceplate frame): they are read from
the controller's SYSVARS.VA (:func:`read_schedules`) or a CSV
``schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm`` the user gives.
"""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.programs.load_data.base import (
    CM,
    NUM,
    Load,
    LoadReader,
    setting,
    unread,
)
from robocal.programs.source import mask

UNSET_KG = 0.0  # a schedule with a mass <= this (factory -9999 sentinel) is not set
_FANUC_MASK = [re.compile(r"^\s*\d+:\s*!.*$", re.MULTILINE), re.compile(r"//[^\n]*")], []
_PAYLOAD = re.compile(r"\bPAYLOAD\s*\[\s*(?:GP(\d+)\s*:\s*)?([^\]:,]*)\s*(?:[:,][^\]]*)?\]", re.IGNORECASE)
ARM_GROUP = 1  # the motion group whose positions robocal corrects (the arm); others' loads are not its
_VA_FIELD = re.compile(r"\$PLST_GRP1\s*\[\s*(\d+)\s*\]\s*\.\s*\$(PAYLOAD(?:_[XYZ])?)\b[^=\n]*=\s*" + NUM,
                       re.IGNORECASE)
SCHEDULE_COLUMNS = ("schedule", "payload_kg", "payload_x_cm", "payload_y_cm", "payload_z_cm")


class FanucLoads(LoadReader):
    """FANUC TP (module docstring): ``PAYLOAD[n]`` with the schedules the user gives."""

    def __init__(self, schedules: dict[int, Load] | None):
        self.schedules = schedules

    def settings(self, sources, references):
        out = []
        for src in sources:
            masked = mask(src.text, *_FANUC_MASK)
            for m in _PAYLOAD.finditer(masked):
                text = m.group(0)
                if m.group(1) is not None and int(m.group(1)) != ARM_GROUP:
                    continue  # another motion group's payload (a positioner, a second arm)
                if not m.group(2).strip().isdigit():
                    raise unread(src, m.start(), text, "the schedule number is a register or variable")
                n = int(m.group(2))
                if self.schedules is None:
                    raise unread(src, m.start(), text, "the payload schedules live in the controller: give "
                                  "them with --payload-schedules (its SYSVARS.VA, or a CSV "
                                  f"{','.join(SCHEDULE_COLUMNS)})")
                if n not in self.schedules:
                    raise unread(src, m.start(), text, f"payload schedule {n} is not in the schedules given "
                                  f"(they hold {sorted(self.schedules)})")
                load = self.schedules[n]
                out.append(setting(src, m.start(), text, load[0], load[1:]))
        return out


def read_schedules(path: str | Path) -> dict[int, Load]:
    """FANUC payload schedules of motion group 1, the values ``PAYLOAD[n]`` selects.

    From the controller's SYSVARS.VA (``Field: $PLST_GRP1[n].$PAYLOAD ... = kg``,
    ``$PAYLOAD_X/_Y/_Z`` in cm in the faceplate frame) or a CSV with the header
    ``schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm``. A schedule with a mass <= 0
    (the factory's -9999 placeholder) is not set and left out.

    Parameters
    ----------
    path : str or path-like
        The SYSVARS.VA or the CSV.

    Returns
    -------
    dict of int to tuple of 4 floats
        Schedule number -> (kg, centre of mass x, y, z in metres in the flange frame tool0).

    Raises
    ------
    DataError
        An unread file, neither format, a schedule without a mass, or none set.

    See Also
    --------
    rc.filter_program : Uses the payload schedules (``loads``).

    Examples
    --------
    >>> from pathlib import Path
    >>> from robocal.programs import read_schedules
    >>> _ = Path("payloads.csv").write_text("schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm\\n"
    ...                                     "1,32,0,0,18\\n2,82,0,0,34\\n")
    >>> read_schedules("payloads.csv")[2]  # 82 kg, 34 cm out along the faceplate's z
    (82.0, 0.0, 0.0, 0.34)
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("latin-1")
    except OSError as exc:
        raise DataError(f"cannot read payload schedules {path}: {exc.strerror}") from None
    fields: dict[int, dict[str, float]] = {}
    if "$PLST_GRP1" in text.upper():
        for m in _VA_FIELD.finditer(text):
            fields.setdefault(int(m.group(1)), {})[m.group(2).upper()] = float(m.group(3))
    else:
        rows = list(csv.reader(io.StringIO(text)))
        header = [c.strip().lower() for c in rows[0]] if rows else []
        if tuple(header) != SCHEDULE_COLUMNS:
            raise DataError(f"{path.name}: not a SYSVARS.VA with $PLST_GRP1 nor a CSV with the header "
                            f"{','.join(SCHEDULE_COLUMNS)}")
        for k, row in enumerate(rows[1:], start=2):
            if not any(c.strip() for c in row):
                continue
            try:
                n, kg, x, y, z = (float(c) for c in row)
            except ValueError:
                raise DataError(f"{path.name}:{k}: expected 5 numbers ({','.join(SCHEDULE_COLUMNS)})") \
                    from None
            fields[int(n)] = {"PAYLOAD": kg, "PAYLOAD_X": x, "PAYLOAD_Y": y, "PAYLOAD_Z": z}
    out = {}
    for n, f in fields.items():
        if "PAYLOAD" not in f:
            raise DataError(f"{path.name}: payload schedule {n} has no mass ($PAYLOAD)")
        values = [f["PAYLOAD"], *(f.get(f"PAYLOAD_{c}", 0.0) * CM for c in "XYZ")]
        if not np.isfinite(values).all():
            raise DataError(f"{path.name}: payload schedule {n} has a value that is not a number")
        if values[0] > UNSET_KG:
            out[n] = tuple(values)
    if not out:
        raise DataError(f"{path.name}: no payload schedule with a mass > 0 kg")
    return out
