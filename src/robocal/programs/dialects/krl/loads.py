"""The load statements of KUKA KRL programs (the reader interface: :mod:`robocal.programs.load_data`).

``$LOAD = {M m, CM {X x, Y y, Z z, A.., B.., C..}, J {..}}`` (kg, mm in the flange frame), ``$LOAD =
LOAD_DATA[n]``, ``BAS(#TOOL, n)`` and an inline form's ``FDAT_ACT = F`` (tool ``F.TOOL_NO``: the
controller loads ``LOAD_DATA[TOOL_NO]`` with the tool; tool 0, the flange, has no LOAD_DATA and
changes nothing here), and a KSS 8 motion's ``WITH $LOAD = SLOAD(F.TOOL_NO)`` (that motion only).
``LOAD_DATA[n]={M.., CM {..}}`` is read from the program files or a reference ($config.dat). ``M
-1`` is the controller's default load from its machine data: not known here. A bare ``$TOOL =
TOOL_DATA[n]`` leaves ``$LOAD`` as it was (the controller keeps them apart).
"""

from __future__ import annotations

import re

import numpy as np

from robocal.programs.dialects.krl.syntax import COMMENT_RE, MOTION_RE, STRING_RE
from robocal.programs.load_data.base import (
    MM,
    NUM,
    LoadReader,
    setting,
    unread,
)

NULL_TOOL = 0  # KRL tool 0 ($NULLFRAME) has no LOAD_DATA: selecting it sets no load here
_KRL_LITERAL = re.compile(r"\{\s*M\s+" + NUM + r"\s*,\s*CM\s*\{\s*X\s+" + NUM + r"\s*,\s*Y\s+" + NUM
                          + r"\s*,\s*Z\s+" + NUM, re.IGNORECASE)
_KRL_DATA = re.compile(r"^[ \t]*(?:DECL\s+)?(?:GLOBAL\s+)?(?:LOAD\s+)?LOAD_DATA\s*\[\s*(\d+)\s*\]\s*=\s*",
                       re.IGNORECASE | re.MULTILINE)
_KRL_SET = re.compile(r"\$LOAD\b\s*(\.\s*\w+\s*)?=\s*([^\n]*)|BAS\s*\(\s*#TOOL\s*,\s*([^)]*)\)|"
                      r"\bFDAT_ACT\s*=\s*(\w+)", re.IGNORECASE)
_KRL_FDAT = re.compile(r"^[ \t]*(?:DECL\s+)?(?:GLOBAL\s+)?FDAT\s+(\w+)\s*=\s*\{[^}\n]*?\bTOOL_NO\s+(\d+)",
                       re.IGNORECASE | re.MULTILINE)
_KRL_SLOAD = re.compile(r"SLOAD\s*\(\s*(\w+)\s*\.\s*TOOL_NO\s*\)", re.IGNORECASE)


class KRLLoads(LoadReader):
    """KUKA KRL (module docstring)."""

    def __init__(self):
        self.data: dict[int, tuple[float, tuple] | str] = {}  # LOAD_DATA[n] -> (kg, cog m) or why not
        self.fdat: dict[str, int] = {}  # FDAT name -> TOOL_NO
        self.masked: dict[int, str] = {}  # id(ProgramText) -> its masked text (a Path hashes slowly)

    def settings(self, sources, references):
        for src in [*references, *sources]:
            masked = self.masked[id(src)] = src.masked([COMMENT_RE], [STRING_RE])
            for m in _KRL_DATA.finditer(masked):
                lit = _KRL_LITERAL.match(masked, m.end())
                n = int(m.group(1))
                if lit is None:
                    self.data[n] = (f"LOAD_DATA[{n}] at {src.path.name}:{src.line_of(m.start())} is not "
                                    "written as {M .., CM {X .., Y .., Z ..}}")
                elif float(lit.group(1)) < 0:
                    self.data[n] = (f"LOAD_DATA[{n}] has M {lit.group(1)}: the controller's default load "
                                    "from its machine data, not known here")
                else:
                    self.data[n] = (float(lit.group(1)), tuple(float(v) * MM for v in lit.groups()[1:]))
            self.fdat.update({m.group(1).upper(): int(m.group(2)) for m in _KRL_FDAT.finditer(masked)})
        out = []
        for src in sources:
            masked = self.masked[id(src)]
            spans = np.array([m.span() for m in MOTION_RE.finditer(masked)], dtype=np.int64).reshape(-1, 2)
            for m in _KRL_SET.finditer(masked):
                k = np.searchsorted(spans[:, 0], m.start(), side="right") - 1  # the motion line before it
                if k >= 0 and m.start() < spans[k, 1]:
                    continue  # a motion's own WITH $LOAD: at_motion
                text = m.group(0)
                if m.group(4):  # FDAT_ACT = F: the inline form's BAS call loads LOAD_DATA[F.TOOL_NO]
                    if self.fdat.get(m.group(4).upper(), NULL_TOOL) == NULL_TOOL:
                        continue  # tool 0, or an FDAT nobody declares (the filter names its motions)
                    mass, cog = self._data(src, m.start(), text, self.fdat[m.group(4).upper()])
                elif m.group(3) is not None:
                    if not m.group(3).strip().isdigit():
                        raise unread(src, m.start(), text, "the tool number is a variable")
                    if int(m.group(3)) == NULL_TOOL:
                        continue
                    mass, cog = self._data(src, m.start(), text, int(m.group(3)))
                else:
                    mass, cog = self._value(src, m.start(), text, m.group(1), m.group(2))
                out.append(setting(src, m.start(), text, mass, cog))
        return out

    def _data(self, src, at, text, n: int):
        got = self.data.get(n)
        if got is None:
            raise unread(src, at, text, f"LOAD_DATA[{n}] is declared in no file given (the controller "
                          "keeps it in $config.dat: give that with --references)")
        if isinstance(got, str):
            raise unread(src, at, text, got)
        return got

    def _value(self, src, at, text, component, value):
        if component:
            raise unread(src, at, text, "a component of $LOAD is set (the load is read from whole "
                          "assignments)")
        lit = _KRL_LITERAL.match(value.strip())
        if lit:
            if float(lit.group(1)) < 0:
                raise unread(src, at, text, "M -1 is the controller's default load, not known here")
            return float(lit.group(1)), tuple(float(v) * MM for v in lit.groups()[1:])
        data = re.fullmatch(r"\s*LOAD_DATA\s*\[\s*(\d+)\s*\]\s*", value, re.IGNORECASE)
        if data:
            return self._data(src, at, text, int(data.group(1)))
        raise unread(src, at, text, "the load is a variable or computed at run time")

    def at_motion(self, state, target, instruction):
        if instruction is not None:
            src, at = instruction
            masked = self.masked.get(id(src), "")
            end = masked.find("\n", at)
            line = masked[at:end if end >= 0 else len(masked)]
            w = re.search(r"\$LOAD\s*=\s*([^,\n]*(?:\([^)\n]*\))?)", line, re.IGNORECASE)
            if w:
                s = _KRL_SLOAD.search(w.group(1))
                if s is None or s.group(1).upper() not in self.fdat:
                    mass, cog = self._value(src, at, w.group(0), None, w.group(1))
                elif self.fdat[s.group(1).upper()] == NULL_TOOL:
                    return super().at_motion(state, target, instruction)
                else:
                    mass, cog = self._data(src, at, w.group(0), self.fdat[s.group(1).upper()])
                return (mass, *cog), f"{src.path.name}:{src.line_of(at)} ({' '.join(w.group(0).split())})"
        return super().at_motion(state, target, instruction)
