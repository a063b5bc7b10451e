"""FANUC position registers ``PR[n]`` given as a file (``--position-registers``), so that motions
to them can be corrected: their values live in the controller, not in the .ls program.

File format (CSV, one register a row, ``#`` comments and blank lines ignored), the values as the
controller's DATA > Position Reg screen shows a Cartesian register::

    register,x_mm,y_mm,z_mm,w_deg,p_deg,r_deg,config
    5,812.500,-120.000,430.000,180.000,0.000,90.000,"N U T, 0, 0, 0"
    6,300.000,100.000,50.000,180.000,0.000,10.000,"R, 0, 0, -1"

(the second row a SCARA's, :class:`~robocal.programs.dialects.fanuc.configuration.FANUCConfig`).
The controller's own backup of the registers, POSREG.VA, is read when given with ``--references``
(:mod:`robocal.programs.dialects.fanuc.posreg`).

A register's value is read in the user frame and tool frame active at the motion that uses it
(``UFRAME_NUM=n`` / ``UTOOL_NUM=n`` in /MN, in text order). The filter writes the corrected values
to a copy of this file (same rows, only the numbers and configuration changed). A register that a
program given assigns (``PR[5]=LPOS``, ``PR[5,3]=...``, in any of the programs: a PR[] is global) is
computed at run time: its motions are named with where it is written.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from robocal.core.bom import without_bom
from robocal.core.errors import DataError
from robocal.programs.dialects.fanuc.configuration import SCARA
from robocal.programs.dialects.fanuc.sections import main_section
from robocal.programs.source import Number, ProgramText
from robocal.programs.target import Target

HEADER = "register,x_mm,y_mm,z_mm,w_deg,p_deg,r_deg,config"
_NUM = r"\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+))\s*"
_ROW = re.compile(r"^\s*(\d{1,4})\s*," + ",".join([_NUM] * 6)
                  + r",\s*\"?\s*(?:([NF])\s*([UD])\s*([TB])|([LR]))"
                  r"\s*,\s*([-+]?\d{1,3})\s*,\s*([-+]?\d{1,3})\s*,\s*([-+]?\d{1,3})\s*\"?\s*$", re.MULTILINE)
# the frame selections: UFRAME_NUM=n, or the system variable as offline generators write it,
# $MNUFRAMENUM[1]=n (group 1's)
_ACTIVE = re.compile(r"(?:\b|\$MN)(UFRAME_NUM|UTOOL_NUM|UFRAMENUM|UTOOLNUM)(?:\[\s*1\s*\])?\s*=\s*(\d+)\s*;")
# a /MN line that writes PR[n] or an element of it (not a remark)
# (or PR[R[k]]=..., a register known at run time)
_ASSIGNED = re.compile(r"^[ \t]*\d*[ \t]*:[ \t]*PR\[\s*(?:GP1\s*:\s*)?(?:(\d+)\s*(?:,\s*\d+\s*)?"
                       r"(?::[^\]]*)?\]\s*=|(R\[))", re.MULTILINE)


# a /MN line that writes a user or tool frame (UFRAME[n]=PR[m], UTOOL[n]=..., a number known at run time)
_FRAME_WRITTEN = re.compile(r"^[ \t]*\d*[ \t]*:[ \t]*(UFRAME|UTOOL)\[\s*([^\]]+?)\s*\]\s*=", re.MULTILINE)


def frame_writes(sources: list[ProgramText]) -> dict[tuple[str, str], str]:
    """``(UFRAME|UTOOL, number or '*')`` -> ``file:line`` of the first /MN line of ``sources`` that
    writes that frame (``UFRAME[1]=PR[5]``; ``'*'``: a number known at run time, any frame): a
    frame is global, so a position taught in it moves where the frame is at run time."""
    out: dict[tuple[str, str], str] = {}
    for m, where in _main_lines(sources, _FRAME_WRITTEN):
        n = m.group(2)
        out.setdefault((m.group(1), str(int(n)) if n.isdigit() else "*"), where)
    return out


def _main_lines(sources: list[ProgramText], pattern: re.Pattern):
    """``(match, file:line)`` of every match of ``pattern`` in the /MN section of each of
    ``sources`` (:func:`~robocal.programs.dialects.fanuc.sections.main_section`), in order."""
    for src in sources:
        span = main_section(src.text)
        if span is not None:
            for m in pattern.finditer(src.text, *span):
                yield m, f"{src.path.name}:{src.line_of(m.start())}"


def frame_written(writes: dict[tuple[str, str], str], uf: str, ut: str) -> str:
    """Why a position in user frame ``uf`` with tool ``ut`` cannot be corrected because a program
    given writes one of them ('' if none does)."""
    for kind, n, word in (("UFRAME", uf, "user frame"), ("UTOOL", ut, "tool frame")):
        where = writes.get((kind, n), writes.get((kind, "*")))
        if where:
            return f"its {word} {kind}[{n}] is written by the program at run time ({where})"
    return ""


@dataclass
class Registers:
    """The position registers given: ``values`` number -> :class:`Target` (Cartesian, frame and
    tool unset); ``other`` number -> why a motion to it is not corrected (None: a joint register,
    nothing to correct); ``origin``: the file they come from, as said in a reason."""

    values: dict[int, Target]
    other: dict[int, str | None]
    origin: str


def assignments(sources: list[ProgramText]) -> tuple[dict[int, str], list[str]]:
    """Register number -> ``file:line`` of the first /MN line of ``sources`` that writes it
    (``PR[n]=...``, ``PR[n,i]=...``): a PR[] is global, so a write in any program given makes its
    value a run-time one; and the ``file:line`` of the lines writing a register whose number is
    known at run time (``PR[R[k]]=...``, ``PR[R[k],i]=...``: any register may be the one)."""
    out: dict[int, str] = {}
    indirect: list[str] = []
    for m, where in _main_lines(sources, _ASSIGNED):
        if m.group(1) is None:
            indirect.append(where)
        else:
            out.setdefault(int(m.group(1)), where)
    return out, indirect


def is_register_file(text: str) -> bool:
    """Whether ``text`` is a position register file: its first line that is not blank nor a ``#``
    comment is the header."""
    for line in text.splitlines():
        body = without_bom(line.strip())
        if body and not body.startswith("#"):
            return body.replace(" ", "").lower() == HEADER
    return False


def read_registers(src: ProgramText) -> dict[int, Target]:
    """Register number -> a :class:`Target` whose numbers are in ``src`` (frame and tool unset)."""
    text = src.text
    lines = [(m.start(), m.group()) for m in re.finditer(r"[^\n]*", text) if m.group().strip()]
    out: dict[int, Target] = {}
    seen_header = False
    for at, line in lines:
        body = line.strip()
        if body.startswith("#"):
            continue
        if not seen_header:
            if body.replace(" ", "").lower() != HEADER:
                raise DataError(f"{src.where(at)}: a position register file starts with the header {HEADER}")
            seen_header = True
            continue
        m = _ROW.match(text, at, at + len(line))
        if m is None:
            raise DataError(f"{src.where(at)}: expected register,x_mm,y_mm,z_mm,w_deg,p_deg,r_deg,\"N U T, "
                            f"t1, t4, t6\" (a SCARA's \"L|R, t1, t2, t4\"), got {body[:60]!r}")
        n = int(m.group(1))
        if n in out:
            raise DataError(f"{src.where(at)}: PR[{n}] is given twice")
        nums = [Number(m.start(k), m.end(k), m.group(k)) for k in range(2, 8)]
        turns = [int(m.group(k)) for k in (12, 13, 14)]
        if m.group(11):  # a SCARA's (SR-series) 'L|R, t1, t2, t4'
            row = np.array(["LR".index(m.group(11)), SCARA, SCARA, *turns])
            spans = [(m.start(k), m.end(k), m.group(k)) for k in (11, 12, 13, 14)]
        else:
            row = np.array(["NF".index(m.group(8)), "UD".index(m.group(9)), "TB".index(m.group(10)), *turns])
            spans = [(m.start(k), m.end(k), m.group(k)) for k in (8, 9, 10, 12, 13, 14)]
        out[n] = Target(src, at, f"PR[{n}]", nums, config=row, config_spans=spans)
    if not seen_header:
        raise DataError(f"{src.path}: empty position register file (header {HEADER})")
    return out


class ActiveFrames:
    """The UFRAME_NUM / UTOOL_NUM in effect at each offset of one .ls file's /MN section."""

    def __init__(self, src: ProgramText, start: int, stop: int):
        self._at: list[int] = []
        self._state: list[tuple[str | None, str | None]] = []
        uf = ut = None
        for m in _ACTIVE.finditer(src.text, start, stop):
            if m.group(1).startswith("UFRAME"):
                uf = m.group(2)
            else:
                ut = m.group(2)
            self._at.append(m.start())
            self._state.append((uf, ut))

    def at(self, offset: int) -> tuple[str | None, str | None]:
        """``(user frame, tool frame)`` numbers in effect at ``offset`` (None: not set yet)."""
        k = np.searchsorted(self._at, offset) - 1
        return self._state[k] if k >= 0 else (None, None)
