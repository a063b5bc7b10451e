"""The load statements of ABB RAPID programs (the reader interface: :mod:`robocal.programs.load_data`).

A motion runs with its tool's ``tload`` (tooldata ``[robhold, tframe, [mass, [x, y, z], aom, ix, iy,
iz]]``: kg, mm in the wrist frame tool0) plus the payload the last ``GripLoad name`` connected
(loaddata ``[mass, [x, y, z], aom, ix, iy, iz]``: its centre of gravity in mm in the *tool* frame,
turned into tool0 through the tool's tframe; ``GripLoad load0`` disconnects it); a motion's optional
``\\TLoad:=name`` is its total load (the tool's and the payload's together, centre of gravity in
tool0) and replaces both. ``tool0`` and ``load0`` carry nothing.
"""

from __future__ import annotations

import re

import numpy as np

from robocal.core.errors import DataError
from robocal.programs.aggregate import Word, parse_aggregate
from robocal.programs.dialects.rapid.syntax import COMMENT_RE, STRING_RE
from robocal.programs.load_data.base import (
    MM,
    Load,
    LoadReader,
    Setting,
    setting,
    unread,
)
from robocal.programs.source import Number, ProgramText
from robocal.programs.target import Target

_RAPID_DECL = re.compile(r"\b(?:(?:LOCAL|TASK)\s+)?(?:CONST|PERS|VAR)\s+(tooldata|loaddata)\s+"
                         r"([A-Za-z]\w*)\s*(\{[^}]*\})?\s*:=", re.IGNORECASE)
_GRIPLOAD = re.compile(r"\bGripLoad\b\s*([^;]*);", re.IGNORECASE)
_TLOAD = re.compile(r"\\\s*TLoad\s*:=\s*([^,;\\]+)", re.IGNORECASE)
_RAPID_NONE = {"tool0": (0.0, (0.0, 0.0, 0.0)), "load0": (0.0, (0.0, 0.0, 0.0))}


class RapidLoads(LoadReader):
    """ABB RAPID (module docstring): tool loads, GripLoad payloads, ``\\TLoad``."""

    def __init__(self, tools: dict[str, np.ndarray]):
        self.tools = tools  # tool name (lower case) -> tframe 4x4 (m), as the filter reads them
        self.loads: dict[str, tuple[float, tuple] | DataError] = dict(_RAPID_NONE)  # tload / loaddata
        self.masked: dict[int, str] = {}  # id(ProgramText) -> its masked text (a Path hashes slowly)
        self.combined: dict[tuple, tuple[Load, str]] = {}  # (tool, GripLoad) -> the motion's load

    def settings(self, sources, references):
        out = []
        for src in [*references, *sources]:
            masked = self.masked[id(src)] = src.masked([COMMENT_RE], [STRING_RE])
            for m in _RAPID_DECL.finditer(masked):
                end = masked.find(";", m.end())
                tree, _ = parse_aggregate(src, masked, m.end(), len(masked) if end < 0 else end,
                                          f"{m.group(1)} {m.group(2)}")
                tool = m.group(1).lower() == "tooldata"
                for suffix, node in _elements(tree, m.group(3) is not None, tool):
                    load = node[2] if tool and len(node) > 2 else node
                    name = m.group(2) + suffix
                    try:
                        self.loads[name.lower()] = _loaddata(src, m.start(), load, name)
                    except DataError as exc:  # an error only for the motions that use it
                        self.loads[name.lower()] = exc
            if src in references:
                continue
            for m in _GRIPLOAD.finditer(masked):
                name = m.group(1).strip().lower()
                if name not in self.loads:
                    raise unread(src, m.start(), m.group(0), f"loaddata {m.group(1).strip()} is declared in "
                                  "no file given (give its module as a program file or with --references)")
                mass, cog = self._load(name)
                out.append(setting(src, m.start(), m.group(0), mass, cog, grip=True))
        return out

    def at_motion(self, state, target, instruction):
        src, at = instruction if instruction else (target.source, target.offset)
        masked = self.masked.get(id(src), "")
        end = masked.find(";", at)
        own = _TLOAD.search(masked, at, len(masked) if end < 0 else end)
        if own:
            name = own.group(1).strip().lower()
            if name not in self.loads:
                raise unread(src, at, own.group(0), f"loaddata {own.group(1).strip()} is declared in no "
                              "file given")
            mass, cog = self._load(name)
            return (mass, *cog), f"{src.path.name}:{src.line_of(at)} (\\TLoad:={own.group(1).strip()})"
        tool = target.tool.lower()
        grip = state.get("grip")
        key = (tool, id(grip))  # the settings live as long as the reader's caller's list
        if key not in self.combined:
            self.combined[key] = self._combined(target, tool, grip)
        return self.combined[key]

    def _load(self, name: str) -> tuple[float, tuple]:
        """The load data ``name`` declares, or the error reading it (raised where it is used)."""
        got = self.loads[name]
        if isinstance(got, DataError):
            raise got
        return got

    def _combined(self, target: Target, tool: str, grip: Setting | None) -> tuple[Load, str]:
        """The load of a motion with ``tool`` after the GripLoad ``grip`` (None: none yet)."""
        if tool not in self.loads:
            raise unread(target.source, target.offset, target.name, f"the load of tool {target.tool} is not "
                          "known (its tooldata is declared in no file given; give its module with "
                          "--references)")
        m1, c1 = self._load(tool)
        m2 = 0.0 if grip is None else grip.mass
        where = f"tooldata {target.tool}" + ("" if grip is None or not m2 else f" + {grip.where}")
        if m1 + m2 <= 0:
            return (0.0, 0.0, 0.0, 0.0), where
        c2 = np.zeros(3) if grip is None else np.asarray(grip.cog, float)
        frame = self.tools.get(tool, np.eye(4))
        c2 = frame[:3, :3] @ c2 + frame[:3, 3]  # the payload's cog: tool frame -> tool0
        cog = (m1 * np.asarray(c1) + m2 * c2) / (m1 + m2)
        return (m1 + m2, *cog.tolist()), where


def _elements(tree, array: bool, tool: bool, index: tuple[int, ...] = ()) -> list[tuple[str, list]]:
    """``(suffix, aggregate)`` of a declaration's value: itself, or each element of an array
    (``{1}``, ``{2,1}`` ...): a tooldata begins with its robhold word, a loaddata with its mass."""
    leaf = isinstance(tree, list) and tree and isinstance(tree[0], Word if tool else Number)
    if not array or leaf or not isinstance(tree, list):
        return [("{" + ",".join(map(str, index)) + "}" if index else "", tree)]
    return [e for k, node in enumerate(tree, start=1) for e in _elements(node, array, tool, (*index, k))]


def _loaddata(src: ProgramText, at: int, node, name: str) -> tuple[float, tuple]:
    """``(mass kg, cog (3,) m)`` of a loaddata aggregate ``[mass, [x, y, z], [q], ix, iy, iz]``."""
    ok = isinstance(node, list) and len(node) >= 2 and isinstance(node[0], Number) and \
        isinstance(node[1], list) and len(node[1]) == 3 and all(isinstance(v, Number) for v in node[1])
    if not ok:
        if isinstance(node, list) and node and isinstance(node[0], Word):
            raise unread(src, at, name, "its load is not written as numbers")
        raise DataError(f"{src.path.name}:{src.line_of(at)}: malformed load data of {name}: expected "
                        "[mass, [x, y, z], [q1, q2, q3, q4], ix, iy, iz]")
    return node[0].value, tuple(v.value * MM for v in node[1])
