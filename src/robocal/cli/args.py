"""Argument types and helpers shared by the subcommands: numbers, measurements read with the
reader's notes printed, output formats, the FANUC joint option, warnings of a quiet run, whether a
model file is a work cell."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from robocal.core.io import FORMATS as DATA_FORMATS
from robocal.core.io import check_format as check_data_format
from robocal.programs.registry import program_formats

if TYPE_CHECKING:  # annotations only
    from robocal.kinematics.workcell import Cell

# robocal.data.instruments.INSTRUMENTS (a test checks), named here for --instrument's choices
# without importing the data layer (0.4 s) to build the parser
INSTRUMENT_NAMES = ("tracker", "mocap", "camera")


def numbers(count: int | None, unit_hint: str) -> Callable[[str], list[float]]:
    """An argparse ``type``: ``count`` comma-separated numbers (e.g. ``X,Y,Z``; None: one or more,
    the command checks how many); ``unit_hint`` completes the error message (e.g. ``"X,Y,Z in mm"``)."""

    def parse(text: str) -> list[float]:
        try:
            values = [float(v) for v in text.replace(" ", "").split(",") if v]
        except ValueError:
            values = []
        if not values or (count is not None and len(values) != count):
            raise argparse.ArgumentTypeError(f"expected {count or 'some'} comma-separated numbers "
                                             f"({unit_hint}), got {text!r}")
        return values

    return parse


def load_measurements(path: str, robot, quiet: bool = False, fanuc_coupled: bool = False,
                      model_used: bool = True):
    """:func:`robocal.data.inputs.read_measurements`, its notes printed (warnings always)."""
    from robocal.data.inputs import read_measurements

    data, notes = read_measurements(path, robot, fanuc_coupled, model_used)
    for note in notes:
        if not quiet or note.startswith("WARNING"):
            print(note if note.startswith("WARNING") else f"note: {note}")
    return data


# output suffix -> the format written there; an output named for another format is refused
def check_format(path, kind: str, option: str, hint: str = "") -> None:
    """:func:`robocal.core.io.check_format` with the robot languages' campaign program suffixes too
    (from the registry, read only for an output whose suffix or kind is not a data format's)."""
    formats = DATA_FORMATS
    data_suffix = path is not None and Path(path).suffix.lower() in DATA_FORMATS
    if path is not None and not (data_suffix and kind in DATA_FORMATS.values()):
        formats = DATA_FORMATS | program_formats()
    check_data_format(path, kind, option, hint, formats)


def work_cell(spec: str, *, positioner: bool = False) -> Cell | None:
    """The `robocal.Cell` a model argument describes when the command treats it as a work cell,
    else None: a cell with a positioner, or (unless ``positioner``: the command's targets are on a
    plate) with several arms. A single robot, or a file `robocal.load_cell` refuses, is None: the
    robot's loading then says what is wrong with it."""
    import robocal as rc

    try:
        cell = rc.load_cell(spec)
    except rc.RobocalError:
        return None
    return cell if cell.positioners or (not positioner and len(cell.arms) > 1) else None


def print_warnings(command: str, warnings) -> None:
    """The warnings of a quiet run on stderr, one line each (``--quiet`` silences progress and
    summaries, never a warning)."""
    for warning in warnings:
        print(f"robocal {command}: warning: {' '.join(str(warning).split())}", file=sys.stderr)


def add_model_options(parser, robot_help: str, cell_help: str) -> None:
    """The required choice of what is modelled: ``--robot`` (catalog name or model YAML) or
    ``--model CELL.yaml`` (a work cell), each with its subcommand's help."""
    model = parser.add_mutually_exclusive_group(required=True)
    model.add_argument("--robot", help=robot_help)
    model.add_argument("--model", metavar="CELL.yaml", help=cell_help)


def add_fanuc_coupled(parser) -> None:
    """The option that reads joint logs of a FANUC controller (J3 counted from the horizontal)."""
    from robocal.data.joint_conventions import COUPLED_OPTION

    parser.add_argument(COUPLED_OPTION, dest="fanuc_coupled", action="store_true",
                        help="the joints are a FANUC controller's (J3 counted from the horizontal, J3 + J2 "
                             "of the catalog's; robocal's --fanuc programs take them so): convert them")
