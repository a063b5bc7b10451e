"""FANUC position registers from the controller's backup: POSREG.VA, the ASCII dump of
``$POSREG`` (given with ``--references``), and the TP program that loads their corrected values.

POSREG.VA (as a controller's backup writes it; CRLF, numbers ``%9.3f`` with the leading zero of
|x| < 1 dropped)::

    [*POSREG*]$POSREG  Storage: CMOS  Access: RW  : ARRAY[2,100] OF Position Reg
        [1,1] =   'HOME'   Group: 1
      J1 =    60.000 deg   J2 =   -50.000 deg   J3 =    10.000 deg
      J4 =   -10.000 deg   J5 =   -95.000 deg   J6 =   -50.000 deg

        [1,2] =   '' Uninitialized
        [1,10] =   'PICK'
      Group: 1   Config: N U T, 0, 0, 0
      X:  -820.507   Y:  2309.503   Z:   945.836
      W:    90.594   P:    -1.149   R:  -160.248
      EXT1:     0.000 mm

``[g,n]`` is register n of motion group g; ``PR[n]`` in a program is group 1's. A joint register
carries ``Group:`` on its index line; a Cartesian one ``Group: g   Config: ...`` on the next, then
X .. R (mm, deg: the fixed-axis angles of the .ls /POS) and the group's extended axes. The file
holds no UF / UT: a register is read in the user and tool frames active at the motion
(``UFRAME_NUM`` / ``UTOOL_NUM``). A SCARA's (SR-series) Config is ``L|R, t1, t2, t4``.

Delivery. A PR[] is global and the .VA is a listing the controller writes but does not load, so
the corrected values go out as a TP program, :data:`SETTER_NAME` ``.LS``, that a FANUC user loads
like any ASCII program (the ASCII upload option, or compiled with Roboguide / maketp) and runs
once: one line ``PR[n:comment]=P[k]`` a corrected register, each ``P[k]`` in its /POS with the
corrected X .. R, the register's (possibly corrected) CONFIG and the UF / UT its motions run
in. The backup file itself is never written; the programs' .ls files are not changed by a
register's correction (their motions name ``PR[n]``, whose value changes).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from robocal.core.errors import DataError
from robocal.programs.dialects.fanuc.configuration import SCARA
from robocal.programs.dialects.writing import ascii_comment
from robocal.programs.source import Number, ProgramText
from robocal.programs.target import Target

ARM_GROUP = 1  # PR[n] in a program: register n of motion group 1
SETTER_NAME = "PR_CAL"  # the TP program that sets the corrected registers (its file PR_CAL.LS)
SETTER_DECIMALS = 6  # its positions' decimals: 1 nm and 1e-6 deg, the corrected values unrounded
_HEADER = re.compile(r"\[\*POSREG\*\]\$POSREG\b[^\n]*$", re.MULTILINE)  # after <PRE> over HTTP too
# the next variable: [*PROG*]$NAME, [KAREL]NAME (not an entry [g,n])
_NEXT_VARIABLE = re.compile(r"^[^\S\n]*\[(?![^\S\n]*\d)", re.MULTILINE)
# a group or register number of at most 9 digits (a longer one is no controller's: a mangled line)
_ENTRY = re.compile(r"^[ \t]*\[\s*(\d{1,9})\s*,\s*(\d{1,9})\s*\][ \t]*=[ \t]*(?:'([^'\n]*)')?([^\n]*)$",
                    re.MULTILINE)
_NUM = r"([-+]?(?:\d+(?:\.\d*)?|\.\d+))"
_CONFIG = re.compile(r"\bGroup:\s*(\d{1,9})\s+Config:\s*(?:([NF])\s*([UD])\s*([TB])|([LR]))\s*"
                     r"(?:,\s*([-+]?\d{1,3})\s*,\s*([-+]?\d{1,3})\s*,\s*([-+]?\d{1,3}))?[ \t\r]*$",
                     re.MULTILINE)
_VALUES = tuple(re.compile(rf"\b{k}:\s*{_NUM}") for k in ("X", "Y", "Z", "W", "P", "R"))
_EXTENDED = re.compile(r"\b(EXT\d+):\s*(\S+)")


@dataclass
class PositionRegisters:
    """The group-1 registers of one POSREG.VA: ``cartesian`` number -> :class:`Target` (its
    numbers in the file, frame and tool unset); ``other`` number -> why a motion to it is not
    corrected (a joint register: None, nothing to correct; else the reason); ``comments``
    number -> the register's comment as the file has it."""

    cartesian: dict[int, Target]
    other: dict[int, str | None]
    comments: dict[int, str]


def is_posreg(src: ProgramText) -> bool:
    """Whether ``src`` is a POSREG.VA (holds the ``$POSREG`` variable)."""
    return _HEADER.search(src.text) is not None


def read_posreg(src: ProgramText) -> PositionRegisters:
    """The registers of motion group 1 in the POSREG.VA ``src`` (module docstring)."""
    entries = group_entries(src, _HEADER)
    if entries is None:
        raise DataError(f"{src.path.name}: no [*POSREG*]$POSREG variable: not a POSREG.VA")
    out = PositionRegisters({}, {}, {})
    for n, at, a, b, comment, rest in entries:
        out.comments[n] = comment
        name = f"PR[{n}]"
        if "Uninitialized" in rest:
            out.other[n] = (f"{name} is Uninitialized in {src.path.name} (no value at the backup): a program "
                            "not given sets it at run time")
            continue
        if "Group:" in rest:
            out.other[n] = None  # a joint register: the joints are what the arm runs, nothing to correct
            continue
        target = cartesian(src, at, name, a, b)
        if isinstance(target, str):
            out.other[n] = target
        else:
            out.cartesian[n] = target
    return out


def group_entries(src: ProgramText, header: re.Pattern) -> list[tuple[int, int, int, int, str, str]] | None:
    """Motion group 1's entries ``[1,n] = 'comment' ...`` of the position array variable whose
    header line ``header`` matches in the .VA ``src``, as ``(n, offset of the entry, start and end
    of its body, its comment, the rest of its index line)``; None: the file has no such variable."""
    text = src.text
    head = header.search(text)
    if head is None:
        return None
    after = _NEXT_VARIABLE.search(text, head.end() + 1)
    stop = after.start() if after else len(text)
    entries = list(_ENTRY.finditer(text, head.end(), stop))
    return [(int(e.group(2)), e.start(), e.end(), entries[k + 1].start() if k + 1 < len(entries) else stop,
             e.group(3) or "", e.group(4)) for k, e in enumerate(entries) if int(e.group(1)) == ARM_GROUP]


def cartesian(src: ProgramText, at: int, name: str, a: int, b: int) -> Target | str:
    """The Cartesian position ``name`` (a register, a frame) whose body is ``src.text[a:b]``, or why
    it is not corrected."""
    text, where = src.text, f"{src.path.name}:{src.line_of(at)}"
    c = _CONFIG.search(text, a, b)
    if c is None:
        body = " ".join(text[a:b].split())[:60]
        raise DataError(f"{where}: {name}: expected 'Group: g   Config: N U T, t1, t4, t6' (a SCARA's "
                        f"'L|R, t1, t2, t4') then X: Y: Z: W: P: R:, got {body!r}")
    nums = []
    for v in _VALUES:
        m = v.search(text, c.end(), b)
        if m is None:
            return f"{name} in {src.path.name} has no readable {v.pattern[2]} value (******** or missing)"
        nums.append(Number(m.start(1), m.end(1), m.group(1)))
    extended = [f"{k} {v}" for k, v in _EXTENDED.findall(text, c.end(), b) if _nonzero(v)]
    if extended:
        return (f"{name} carries extended axes of its group ({', '.join(extended)}) that move the arm: "
                "not corrected")
    turns = [int(c.group(k)) if c.group(k) else 0 for k in (6, 7, 8)]
    if c.group(5):  # a SCARA: the hand and three turns (none written: the controller's nearest, 0)
        row = np.array(["LR".index(c.group(5)), SCARA, SCARA, *turns])
        spans = [(c.start(k), c.end(k), c.group(k)) for k in (5, 6, 7, 8) if c.group(k)]
    else:
        row = np.array(["NF".index(c.group(2)), "UD".index(c.group(3)), "TB".index(c.group(4)), *turns])
        spans = [(c.start(k), c.end(k), c.group(k)) for k in range(2, 9) if c.group(k)]
    return Target(src, at, name, nums, config=row, config_spans=spans)


def _nonzero(value: str) -> bool:
    """An extended axis' value that is not 0 (``********``, unset, counts as not 0)."""
    try:
        return float(value) != 0.0
    except ValueError:
        return True


def position_block(k: int, uf: str, ut: str, config: str, values: Sequence[float],
                   decimals: int) -> list[str]:
    """The lines of a Cartesian ``P[k]`` in a TP program's /POS (motion group 1): user frame
    ``uf``, tool frame ``ut``, the CONFIG text ``config``, ``values`` X, Y, Z (mm), W, P, R (deg)
    written with ``decimals`` decimals."""
    x, y, z, w, p, r = (f"{v:{decimals + 6}.{decimals}f}" for v in values)
    return [f"P[{k}]{{", "   GP1:", f"\tUF : {uf}, UT : {ut},\t\tCONFIG : '{config}',",
            f"\tX = {x}  mm,\tY = {y}  mm,\tZ = {z}  mm,", f"\tW = {w} deg,\tP = {p} deg,\tR = {r} deg", "};"]


def _register_comment(text: str) -> str:
    """A register's comment as it can stand in ``PR[n:comment]``: printable ASCII without quotes,
    brackets or ``;`` (which would end the label or the line)."""
    return "".join(" " if ch in "[];" else ch for ch in ascii_comment(text)).strip()


def setter_program(corrected: ProgramText, used: dict[int, tuple[str, str]], scheme) -> str:
    """The TP program (:data:`SETTER_NAME`) that sets the registers ``used`` (number -> (user
    frame, tool frame) of their motions) to their values in ``corrected``, the filtered copy of
    the POSREG.VA: ``PR[n:comment]=P[k]`` a register, ``P[k]`` holding the corrected values.
    ``scheme``: the dialect's configuration scheme (the CONFIG text)."""
    regs = read_posreg(corrected)
    nl = "\r\n" if "\r\n" in corrected.original else "\n"
    lines, blocks = [], []
    for k, n in enumerate(sorted(used), start=1):
        t = regs.cartesian[n]
        uf, ut = used[n]
        x, y, z, w, p, r = t.values()
        comment = _register_comment(regs.comments.get(n, ""))
        label = f"PR[{n}:{comment}]" if comment else f"PR[{n}]"
        lines.append(f"{k:>4}:  {label}=P[{k}]    ;")
        blocks += position_block(k, uf, ut, scheme.text(t.config), (x, y, z, w, p, r), SETTER_DECIMALS)
    head = [f"/PROG  {SETTER_NAME}", "/ATTR", "OWNER\t\t= MNEDITOR;",
            f"COMMENT\t\t= \"{ascii_comment(corrected.path.name)[:16]}\";", f"LINE_COUNT\t= {len(lines)};",
            "PROTECT\t\t= READ_WRITE;", "DEFAULT_GROUP\t= 1,*,*,*,*;", "/MN"]
    return nl.join([*head, *lines, "/POS", *blocks, "/END", ""])
