"""One Cartesian target of a program (:class:`Target`): the numbers of its pose as written, the
frame and tool it is used with, its configuration data (:mod:`robocal.programs.model` gathers
them into a :class:`~robocal.programs.model.Program`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from robocal.programs.source import Number, ProgramText

IDENTITY = "identity"  # name of the identity frame / tool (world, wobj0, tool0, $NULLFRAME ...)


@dataclass
class Target:
    """One Cartesian target. ``numbers``: the pose numbers as written (vendor order and units);
    ``frame`` / ``tool``: keys into :attr:`Program.frames` / :attr:`Program.tools`;
    ``config``: the vendor's configuration row (None: the target has none); ``config_spans``:
    whatever the dialect needs to rewrite it; ``qnear``: joints (rad) a controller would start
    its search from (URScript ``qnear=``), else None."""

    source: ProgramText
    offset: int
    name: str
    numbers: list[Number]
    frame: str = IDENTITY
    tool: str = IDENTITY
    config: np.ndarray | None = None
    config_spans: object = None
    qnear: np.ndarray | None = None
    order: int = 0  # position in execution order (first execution, :mod:`robocal.programs.flow`)
    monitored: bool = True  # False: the motion runs with configuration monitoring off (RAPID ConfL Off)
    external: str = ""  # external-axis values the target carries (a track, gantry or positioner), as text
    # the same values as data: the program's axis name (eax_b, E2, E1 of GP2 ...) -> value as written
    # (mm or deg); empty: none or not read by the dialect
    axes: dict[str, float] = field(default_factory=dict)

    @property
    def line(self) -> int:
        return self.source.line_of(self.offset)

    @property
    def where(self) -> str:
        return f"{self.source.path.name}:{self.line} ({self.name})"

    def values(self) -> np.ndarray:
        return np.array([n.value for n in self.numbers], dtype=float)
