"""The tool file of a Yaskawa controller, ``TOOL.CND`` (in a CMOS backup or the pendant's save of
the condition files): per tool number its tool frame and the load the arm carries with it.

One block per tool::

    //TOOL 2
    ///NAME GRIPPER PART          (a ///CRC line may stand before it; /// lines are passed over)
    0.000,0.000,250.000,0.0000,0.0000,90.0000     X, Y, Z (mm), Rx, Ry, Rz (deg): the tool frame
    0.000,0.000,120.000                           Xg, Yg, Zg (mm): the load's centre of gravity
    35.000                                        W (kg): the load's mass
    0.000,0.000,0.000                             Ix, Iy, Iz (kg m^2) about the centre of gravity
    0.000,0,1                                     (not read)

The tool frame holds the numbers of the pendant's tool screen (those of ``--tool n=X,Y,Z,Rx,Ry,Rz``).
The load is the controller's "tool load information": the weight W, the centre of gravity Xg, Yg,
Zg in the flange coordinates and the moments of inertia about it, registered in the tool file. It
is the whole load on the flange with that tool: a Yaskawa controller has no other load setting, so
a cell that grips a part defines a second tool number with the same frame and the load with the
part, and the positions taught with the part carry that number (``///TOOL n``).

Where the layout comes from: the controllers' manuals (the NX100 / XRC "ARM control" chapter: the
tool load information is W, Xg, Yg, Zg, Ix, Iy, Iz, set in the tool file), Yaskawa's developer pages
(the tool "includes not only the end-of-arm tooling, but any possible payload": one tool per
payload) and real controller backups (the TOOL.CND files in the public repositories
lukelalondePZ/Fiberdome-GP88-Spindle-Cell, SinaiAranda/motoman_sda20d_sys and
lukelalondePZ/Komatsu-Press-Demo): every block has a line of six numbers, then lines of three,
one, three and three numbers. The manuals' three groups (W; Xg, Yg, Zg; Ix, Iy, Iz) fit the one
and the two threes; the first three is the centre of gravity, since a real file writes it
negative (-16.507,-21.039,-136.477 with W 104.011): a moment of inertia is never negative.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from robocal.core.errors import DataError
from robocal.programs.source import ProgramText

MM = 1e-3  # m
_BLOCK = re.compile(r"^//TOOL\s+(\d+)\s*$", re.MULTILINE)
MAX_DIGITS = 6  # a tool number longer than this is no tool number (a controller has up to 64 or 128)
_COUNTS = (6, 3, 1)  # numbers on the first three lines of a block: frame, centre of gravity, W
_WHAT = ("X,Y,Z,Rx,Ry,Rz (the tool frame)", "Xg,Yg,Zg (the centre of gravity)", "W (the mass)")


@dataclass(frozen=True)
class ToolEntry:
    """One tool of the file: ``frame`` X, Y, Z (mm), Rx, Ry, Rz (deg) as written; ``mass`` kg
    and ``cog`` (3,) m in the flange frame; ``line`` of its ``//TOOL n`` (1-based)."""

    number: str
    name: str
    frame: tuple[float, ...]
    mass: float
    cog: tuple[float, float, float]
    line: int


def is_tool_file(src: ProgramText) -> bool:
    """A TOOL.CND: a ``//TOOL n`` line."""
    return _BLOCK.search(src.text) is not None


def read_tool_file(src: ProgramText) -> dict[str, ToolEntry]:
    """Every tool of a TOOL.CND (module docstring): tool number ('0', '1', ...) -> its entry.

    Raises
    ------
    DataError
        A block whose first three number lines are not 6, 3 and 1 numbers, a value that is not a
        finite number, a tool number given twice, or no ``//TOOL n`` block at all.
    """
    out: dict[str, ToolEntry] = {}
    block: tuple[str, str, int, list[list[float]]] | None = None  # number, name, line, number lines

    def close() -> None:
        if block is None:
            return
        number, name, line, rows = block
        if len(rows) < len(_COUNTS):
            raise DataError(f"{src.path.name}:{line}: tool {number} has {len(rows)} line(s) of numbers: "
                            f"expected {', '.join(_WHAT)}, one per line")
        if number in out:
            raise DataError(f"{src.path.name}:{line}: tool {number} is given twice")
        cog = tuple(v * MM for v in rows[1])
        out[number] = ToolEntry(number, name, tuple(rows[0]), rows[2][0], cog, line)

    for k, raw in enumerate(src.text.split("\n"), start=1):
        line = raw.strip()
        head = _BLOCK.match(line)
        if head:
            close()
            if len(head.group(1)) > MAX_DIGITS:
                raise DataError(f"{src.path.name}:{k}: malformed //TOOL line: a tool number of more than "
                                f"{MAX_DIGITS} digits")
            block = (str(int(head.group(1))), "", k, [])
            continue
        if block is None or not line:
            continue
        if line.startswith("///"):
            if line[3:].upper().startswith("NAME"):
                block = (block[0], line[7:].strip(), block[2], block[3])
            continue
        if line.startswith("//"):  # another section: the block ends
            close()
            block = None
            continue
        rows = block[3]
        if len(rows) >= len(_COUNTS):
            continue  # the inertia and the last line: not read
        values = _numbers(line)
        if values is None or len(values) != _COUNTS[len(rows)]:
            raise DataError(f"{src.path.name}:{k}: malformed line {line[:60]!r} of tool {block[0]}: expected "
                            f"{_WHAT[len(rows)]} as numbers separated by commas")
        rows.append(values)
    close()
    if not out:
        raise DataError(f"{src.path.name}: no //TOOL n block: not a Yaskawa tool file (TOOL.CND)")
    return out


def _numbers(line: str) -> list[float] | None:
    """The comma-separated finite numbers of ``line``, None when one is not."""
    try:
        values = [float(v) for v in line.split(",")]
    except ValueError:
        return None
    return values if all(math.isfinite(v) for v in values) else None
