"""The control groups of an INFORM job and the external-axis values its motions move with.

A job names its control groups in its ``//INST`` header: ``///GROUP1 RB1,BS1`` (the robot on base
axes, a track) and ``///GROUP2 ST1`` (a station, a positioner, moving with the robot's motions
through ``+MOVJ EC00001``), or ``///GROUP1 RB1,ST1`` (robot and station in one group: the station's
position ``EC00001`` written in the robot's instruction). A motion's external values are its base
axes (``BC``/``BP``, the group's ``BS``), its stations' positions (``EC``/``EX`` with the robot or
after a ``+``, each ``+`` part the next group's) with the units that move (:class:`Moved`).
Station-coordinated motions (``SMOVJ``/``SMOVL``/``SMOVC`` without a conveyor ``CV#``) move the
robot relative to the station's plate: the robot's target is then carried by that station.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

_GROUP = re.compile(r"^///GROUP(\d+)\s+([^\r\n]*?)\s*$", re.MULTILINE)
_STATION = re.compile(r"^S(?:T)?\d+$")  # ST1 (DX100, YRC1000) or S1 (older controllers)
_BASE = re.compile(r"^BS\d+$")
STATION_KINDS = ("EC", "EX", "LEX")  # a station's positions: in the job, a variable, a local variable
BASE_KINDS = ("BC", "BP", "LBP")


@dataclass(frozen=True)
class Groups:
    """The units of each ``///GROUPn`` line of a job, in order."""

    groups: tuple[tuple[str, ...], ...] = ()

    @property
    def robot(self) -> tuple[str, ...]:
        """The robot's group (the first with an ``RB`` unit; the first group if none has one)."""
        return next((g for g in self.groups if any(u.startswith("RB") for u in g)),
                    self.groups[0] if self.groups else ())

    @property
    def others(self) -> list[tuple[str, ...]]:
        """The groups after the robot's, in order: what the ``+`` parts of an instruction move."""
        robot = self.robot
        return [g for g in self.groups if g is not robot]

    def station_of(self, part: int) -> str | None:
        """The station that ``EC``/``EX`` values in part ``part`` of an instruction move (0: the
        robot's own part; k: the k-th ``+`` part), None when no single station is there."""
        group = self.robot if part == 0 else self.others[part - 1] if part <= len(self.others) else ()
        stations = [u for u in group if _STATION.match(u)]
        return stations[0] if len(stations) == 1 else None

    @property
    def on_track(self) -> bool:
        """The robot is on base axes (a ``BS`` unit in its group)."""
        return any(_BASE.match(u) for u in self.robot)

    @property
    def stations(self) -> list[str]:
        return [u for g in self.groups for u in g if _STATION.match(u)]


def job_groups(text: str) -> Groups:
    """The control groups of a job's text (empty when it names none)."""
    return Groups(tuple(tuple(u.strip().upper() for u in m.group(2).split(",") if u.strip())
                        for m in _GROUP.finditer(text)))


@dataclass
class Moved:
    """What moves with one motion besides the robot: ``values``: ``(unit, label, kind, numbers or None,
    unit of the numbers)`` for each base-axis or station position written in it."""

    values: list[tuple[str, str, str, list[float] | None, str]] = field(default_factory=list)

    def text(self) -> str:
        """The values as a summary, e.g. ``BC00001 (BS1), +MOVJ EC00000 (ST1)``."""
        return ", ".join(f"{label} ({unit})" for unit, label, *_ in self.values)

    def station(self) -> list[tuple[str, str, list[float] | None, str]]:
        """The station positions: ``(unit, label, numbers or None, unit of the numbers)``."""
        return [(u, label, nums, how) for u, label, kind, nums, how in self.values if kind in STATION_KINDS]
