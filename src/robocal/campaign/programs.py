"""Robot programs that drive a measurement campaign, in every language of the registry
(:mod:`robocal.programs.registry`; each language's writer: ``programs/dialects/<language>/campaign.py``):
ABB RAPID, KUKA KRL, FANUC TP (.ls), Universal Robots URScript, Yaskawa INFORM (.JBI), Staubli VAL3
(an application folder).

Each program moves to the planned joint positions in the measuring order, waits ``settle_s``
seconds for the robot to come to rest, and calls a named procedure at each pose where the user
triggers the tracker (the generated procedure only shows a message: replace its body with the
cell's trigger, a digital output or a socket message). Joint values are written in the robot's
own joint convention: the catalog's joint zeros and signs are the controller's, so the planned
values go out unchanged, in each language's unit, except where a language's writer says otherwise
(FANUC's J3 counted from the horizontal, INFORM's Cartesian positions). What each language's
program looks like is in the docstring of its writer.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.core.io import write_all
from robocal.ik.scara import is_scara
from robocal.kinematics.model import Robot
from robocal.programs.dialects.writing import (
    DEFAULT_PROCEDURE,
    DEFAULT_SETTLE_S,
    DEFAULT_SPEED_PERCENT,
    DEGREE_DECIMALS,
    ExternalAxes,
    fixed_point,
)
from robocal.programs.registry import dialects

__all__ = ["DEGREE_DECIMALS", "campaign_outputs", "campaign_programs", "fixed_point", "program_options",
           "refuse_tracks", "write_campaign"]


def program_options() -> list:
    """The languages robocal writes campaign programs in, in the order it writes them."""
    return sorted(dialects(), key=lambda d: d.campaign_rank)


def campaign_outputs(programs: dict[str, str | Path], procedure: str = DEFAULT_PROCEDURE) -> list[str]:
    """The files ``programs`` (language key -> path) will write or overwrite, checked before
    planning (a KRL program's .dat beside its .src, the files of an existing VAL3 application)."""
    return [p for d in program_options() if programs.get(d.key) is not None
            for p in d.campaign_paths(Path(programs[d.key]), procedure)]


def refuse_tracks(programs: dict[str, str | Path], robot: Robot, poses: str) -> None:
    """Refuse programs of languages that cannot drive ``robot``'s prismatic joint (a track; a SCARA's
    quill: the languages whose writers drive a SCARA, ``campaign_scara``, write it);
    ``poses``: the planned poses' file, named as what to drive instead."""
    if is_scara(robot):  # a SCARA's quill is its own joint 3, not an external axis
        wanted = [str(programs[d.key]) for d in program_options()
                  if programs.get(d.key) is not None and not d.campaign_scara]
        if wanted:
            raise DataError(f"{robot.name} is a SCARA: campaign programs are written for it in "
                            f"{', '.join(d.title for d in program_options() if d.campaign_scara)} only, not "
                            f"{', '.join(wanted)}; drive the poses of {poses} (the quill q3 in mm) with your "
                            "own program")
        return
    wanted = [str(programs[d.key]) for d in program_options()
              if programs.get(d.key) is not None and d.campaign_refuses_tracks]
    if wanted and robot.has_prismatic:
        raise DataError(f"{robot.name} has a prismatic joint (a track): campaign programs with external "
                        f"axes are not written ({', '.join(wanted)}); drive the poses of {poses} "
                        "(e1_mm and the arm's joints) with your own program")


def write_campaign(texts: dict[str, str], programs: dict[str, str | Path]) -> None:
    """Write every output (:func:`robocal.core.io.write_all`: all or none), creating the folders of
    the languages whose programs are folders (VAL3); a folder created here and left empty by a
    failure is removed."""
    folders = [d.campaign_folder(Path(programs[d.key])) for d in program_options()
               if programs.get(d.key) is not None]
    created = [f for f in folders if f is not None and not f.is_dir()]
    for f in created:
        f.mkdir()
    try:
        write_all(texts)
    except BaseException:
        for f in created:
            if not any(f.iterdir()):
                f.rmdir()
        raise


def campaign_programs(joints: np.ndarray, robot: Robot, programs: dict[str, str | Path], *,
                      speed_percent: float = DEFAULT_SPEED_PERCENT, settle_s: float = DEFAULT_SETTLE_S,
                      procedure: str = DEFAULT_PROCEDURE, comment: str = "",
                      external: ExternalAxes | None = None) -> dict[str, str]:
    """The campaign programs visiting ``joints`` ``(N, 6)`` (rad) of ``robot`` (its nominal model,
    the flange its tool) in order, a positioner's values ``external`` (one row per pose, see
    `robocal.programs.dialects.writing.ExternalAxes`) moving with them: ``programs`` maps a
    language key to the path to write (module docstring); returns file path -> text, in
    :func:`program_options` order. A language whose programs drive no positioner is refused when
    ``external`` is given."""
    q = np.asarray(joints, float)
    wanted = [d for d in program_options() if programs.get(d.key) is not None]
    blind = [d.title or d.name for d in wanted if not d.campaign_external]
    if external is not None and blind:
        able = ", ".join(d.title or d.name for d in program_options() if d.campaign_external)
        raise DataError(f"campaign programs in {', '.join(blind)} do not drive a positioner "
                        f"({external.unit}): write them in {able}")
    texts: dict[str, str] = {}
    for d in program_options():
        if programs.get(d.key) is not None:
            options = {} if external is None else {"external": external.in_language(d)}  # its axis names
            texts.update(d.campaign_files(q, robot, Path(programs[d.key]), speed_percent=speed_percent,
                                          settle_s=settle_s, procedure=procedure, comment=comment, **options))
    return texts
