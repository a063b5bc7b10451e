"""The controller's own VAR.DAT (a CMOS backup of a DX100/DX200/YRC1000): the global variables,
each section a ``///`` line and one line per variable in number order::

    //VAR
    ///PFNUM 6,0,0,0
    ///SHARE 250,250,250,250,250,250,0,0
    ///B
    0,0,0,0,0,0,0,0,0,0                 (B000..B009, ten a line; I, D, R, S alike)
    ///P
    "UNUSED"                             P000: no value saved
    "PULSE"0,0,3,000000000000000000000000,0,0,2,-76037,-66182,0,4682,0,0,0
    "RECTAN"0,0,3,001010000000000000000000,0,16,-863.111,979.613,492.219,178.9297,-0.1487,123.0482,0.0000,0.0000
    ///BP
    ///EX

A P line is ``"KIND"a,b,tool,FORM,c,TYPE,values``: ``FORM`` the 24 form (RCONF) flags as digits in
the order of a job's ``///RCONF`` (flip, arm, front/back, R, T, S, ...), ``TYPE`` the coordinate
system (0 pulses; 16 BASE; 17 ROBOT; 18 and 19 user or tool coordinates: the position variable
data types of Yaskawa's high-speed Ethernet server), then S..T (pulses) or X, Y, Z (mm), Rx, Ry, Rz
(deg), then the external axes. Read from the public backups lukelalondePZ/Komatsu-Press-Demo and
Fiberdome-GP88-Spindle-Cell and SinaiAranda/motoman_sda20d_sys (layout only, nothing copied): in
Komatsu-Press-Demo's the tool field is 3 or 4 on pulse and BASE positions alike (the cell's two
grippers), so it is the tool, not a frame. BASE and ROBOT positions are corrected; a user- or
tool-coordinate one (types 18, 19) is named: which field holds its frame number is not settled by
those files. The older layout, a job's ``//POS`` syntax under ``//P`` (``P0001=...``), is read by
:mod:`robocal.programs.dialects.inform.reader`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from robocal.core.bom import BOM_PATTERN
from robocal.programs.source import ProgramText

_HEAD = re.compile(rf"^{BOM_PATTERN}//VAR\s*$", re.MULTILINE)
_P_SECTION = re.compile(r"^///P\s*$")
_LINE = re.compile(r'^"(\w+)"')
# tool number and coordinate type of at most 9 digits: a longer one is no controller's (a mangled line)
_USED = re.compile(r"(\d+),(\d+),(\d{1,9}),([01]{6,}),(\d+),(\d{1,9}),(.*)$")
TYPES = {0: "PULSE", 16: "BASE", 17: "ROBOT"}  # coordinate types read; 18, 19: user or tool coordinates


@dataclass(frozen=True)
class Entry:
    """One line of the ``///P`` section: P variable ``index``; ``kind`` 'UNUSED', 'PULSE',
    'RECTAN' ('' for a line of another layout); for a used one its ``tool``, coordinate ``type``
    (None: not the layout above), the form digits' and the values' spans (byte offsets)."""

    index: int
    start: int
    end: int  # the line's end, its line end included
    kind: str
    tool: str = "0"
    type: int | None = None
    form: tuple[int, int] = (0, 0)
    values: tuple[int, int] = (0, 0)


def is_cmos_variables(src: ProgramText) -> bool:
    """A VAR.DAT of a controller's CMOS backup (``//VAR`` with a ``///P`` section)."""
    return _HEAD.search(src.text) is not None and re.search(r"^///P\s*$", src.text, re.MULTILINE) is not None


def entries(src: ProgramText) -> list[Entry]:
    """Every line of the ``///P`` section, in number order (P000 first)."""
    out: list[Entry] = []
    inside = False
    pos = 0
    for raw in src.text.split("\n"):
        start, pos = pos, pos + len(raw) + 1
        line = raw.rstrip("\r")
        if line.startswith("//"):
            inside = _P_SECTION.match(line) is not None
            continue
        if not inside:
            continue
        end = min(pos, len(src.text))
        m = _LINE.match(line)
        if m is None:
            out.append(Entry(len(out), start, end, ""))
            continue
        f = _USED.match(line, m.end())
        if f is None:
            out.append(Entry(len(out), start, end, m.group(1).upper()))
            continue
        out.append(Entry(len(out), start, end, m.group(1).upper(), str(int(f.group(3))), int(f.group(6)),
                         (start + f.start(4), start + f.end(4)), (start + f.start(7), start + f.end(7))))
    return out
