"""The load statements of Staubli VAL3 programs: none (:mod:`robocal.programs.load_data`).

No statement or data type of the language holds a load (a ``tool`` is a frame and its gripper
output, an ``mdesc`` speeds, accelerations and blending): ``--payload``.
"""

from __future__ import annotations

from robocal.programs.load_data.base import LoadReader


class NoLoads(LoadReader):
    """Staubli VAL3: no statement or data type of the language holds a load."""

    none = "a VAL3 program holds no load data"
    hint = ""
