"""The load data a program sets, as each vendor writes it: the statements that set the load the
arm carries, read into kg and metres in the flange frame tool0 (the frame of ``--tool``).

The load is the controller's: the total mass on the flange (tool and workpiece) and its centre of
mass. Per dialect:

* ABB RAPID: a motion runs with its tool's ``tload`` (tooldata ``[robhold, tframe, [mass, [x, y,
  z], aom, ix, iy, iz]]``: kg, mm in the wrist frame tool0) plus the payload the last ``GripLoad
  name`` connected (loaddata ``[mass, [x, y, z], aom, ix, iy, iz]``: its centre of gravity in mm
  in the *tool* frame, turned into tool0 through the tool's tframe; ``GripLoad load0``
  disconnects it); a motion's optional ``\\TLoad:=name`` is its total load (the tool's and the
  payload's together, centre of gravity in tool0) and replaces both. ``tool0`` and ``load0``
  carry nothing.
* KUKA KRL: ``$LOAD = {M m, CM {X x, Y y, Z z, A.., B.., C..}, J {..}}`` (kg, mm in the flange
  frame), ``$LOAD = LOAD_DATA[n]``, ``BAS(#TOOL, n)`` and an inline form's ``FDAT_ACT = F``
  (tool ``F.TOOL_NO``: the controller loads ``LOAD_DATA[TOOL_NO]`` with the tool; tool 0, the
  flange, has no LOAD_DATA and changes nothing here), and a KSS 8
  motion's ``WITH $LOAD = SLOAD(F.TOOL_NO)`` (that motion only). ``LOAD_DATA[n]={M.., CM {..}}``
  is read from the program files or a reference ($config.dat). ``M -1`` is the controller's
  default load from its machine data: not known here. A bare ``$TOOL = TOOL_DATA[n]`` leaves
  ``$LOAD`` as it was (the controller keeps them apart).
* FANUC TP: ``PAYLOAD[n]`` selects payload schedule n of motion group 1, whose values live in the
  controller (``$PLST_GRP1[n].$PAYLOAD`` kg, ``$PAYLOAD_X/_Y/_Z`` cm in the faceplate frame): they
  are read from the controller's SYSVARS.VA (:func:`read_schedules`) or a CSV
  ``schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm`` the user gives.
* URScript: ``set_payload(m, [x, y, z])`` / ``set_target_payload(m, [x, y, z], ...)`` (kg, m from
  the tool flange, in its frame), ``set_payload(m)`` (the centre of gravity kept),
  ``set_payload_mass(m)``, ``set_payload_cog([x, y, z])``.

A statement this cannot read (a variable, a computed value, ``$LOAD.M = ..``, ``PAYLOAD[R[1]]``,
a ``LOAD_DATA[n]`` or schedule nobody gave) raises :class:`~robocal.errors.DataError` naming it
and how to give the load instead: a motion corrected with a load it does not carry would look
right and be wrong.
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robocal.errors import DataError
from robocal.programs.aggregate import Word, parse_aggregate
from robocal.programs.fanuc_ls import FanucDialect
from robocal.programs.krl import COMMENT_RE, MOTION_RE, STRING_RE, KRLDialect
from robocal.programs.model import Dialect, Target
from robocal.programs.rapid import RapidDialect
from robocal.programs.source import NUMBER_RE, Number, ProgramText, mask
from robocal.programs.urscript import URScriptDialect

MM, CM = 1e-3, 1e-2  # m
NULL_TOOL = 0  # KRL tool 0 ($NULLFRAME) has no LOAD_DATA: selecting it sets no load here
UNSET_KG = 0.0  # a FANUC schedule with a mass <= this (factory -9999 sentinel) is not set
STATEMENT_CHARS = 60  # a load statement quoted in messages is shortened to this
_NUM = f"({NUMBER_RE.pattern})"
_ADVICE = "give the load with --payload KG[,X,Y,Z] (every motion) instead"

Load = tuple[float, float, float, float]  # kg, then the centre of mass x, y, z (m) in tool0


@dataclass(frozen=True)
class Setting:
    """A statement that sets the load, at offset ``at`` of ``path`` (``where``: file:line and the
    statement). ``mass`` kg and ``cog`` (3,) m replace the current ones; None keeps them (URScript's
    partial setters). ``grip``: a RAPID payload (GripLoad), added to the tool's load, its ``cog``
    in the tool frame."""

    path: Path
    at: int
    where: str
    mass: float | None = None
    cog: tuple[float, float, float] | None = None
    grip: bool = False


def _setting(src: ProgramText, at: int, text: str, mass, cog, grip: bool = False) -> Setting:
    text = " ".join(text.split())
    text = text if len(text) <= STATEMENT_CHARS else text[:STATEMENT_CHARS - 3] + "..."
    where = f"{src.path.name}:{src.line_of(at)} ({text})"
    return Setting(src.path, at, where, None if mass is None else float(mass),
                   None if cog is None else tuple(float(c) for c in cog), grip)


def _unread(src: ProgramText, at: int, text: str, why: str) -> DataError:
    return DataError(f"{src.path.name}:{src.line_of(at)}: {' '.join(text.split())[:STATEMENT_CHARS]}: {why}; "
                     f"{_ADVICE}")


class LoadReader:
    """One dialect's load statements: :meth:`settings` in the program files, :meth:`at_motion` the
    load a motion runs with given the last settings executed before it."""

    def settings(self, sources: list[ProgramText], references: list[ProgramText]) -> list[Setting]:
        """Every statement of ``sources`` that sets the load, in text order per file."""
        return []

    def at_motion(self, state: dict, target: Target, instruction: tuple[ProgramText, int] | None) \
            -> tuple[Load, str] | None:
        """``(load, where it was set)`` of a motion to ``target`` after the settings in ``state``
        (``'load'``/``'grip'`` -> the last :class:`Setting` merged; absent: none executed);
        ``instruction``: the motion instruction's file and offset. None: the program sets none."""
        last = state.get("load")
        if last is None or last.mass is None:
            return None
        return (last.mass, *(last.cog or (0.0, 0.0, 0.0))), last.where


# ----------------------------------------------------------------------------------------- RAPID
_RAPID_MASK = [re.compile(r"![^\n]*")], [re.compile(r'"(?:[^"\n]|"")*"')]
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
            masked = self.masked[id(src)] = mask(src.text, *_RAPID_MASK)
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
                    raise _unread(src, m.start(), m.group(0), f"loaddata {m.group(1).strip()} is declared in "
                                  "no file given (give its module as a program file or with --references)")
                mass, cog = self._load(name)
                out.append(_setting(src, m.start(), m.group(0), mass, cog, grip=True))
        return out

    def at_motion(self, state, target, instruction):
        src, at = instruction if instruction else (target.source, target.offset)
        masked = self.masked.get(id(src), "")
        end = masked.find(";", at)
        own = _TLOAD.search(masked, at, len(masked) if end < 0 else end)
        if own:
            name = own.group(1).strip().lower()
            if name not in self.loads:
                raise _unread(src, at, own.group(0), f"loaddata {own.group(1).strip()} is declared in no "
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
            raise _unread(target.source, target.offset, target.name, f"the load of tool {target.tool} is not "
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
            raise _unread(src, at, name, "its load is not written as numbers")
        raise DataError(f"{src.path.name}:{src.line_of(at)}: malformed load data of {name}: expected "
                        "[mass, [x, y, z], [q1, q2, q3, q4], ix, iy, iz]")
    return node[0].value, tuple(v.value * MM for v in node[1])


# ------------------------------------------------------------------------------------------- KRL
_KRL_LITERAL = re.compile(r"\{\s*M\s+" + _NUM + r"\s*,\s*CM\s*\{\s*X\s+" + _NUM + r"\s*,\s*Y\s+" + _NUM
                          + r"\s*,\s*Z\s+" + _NUM, re.IGNORECASE)
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
            masked = self.masked[id(src)] = mask(src.text, [COMMENT_RE], [STRING_RE])
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
                        raise _unread(src, m.start(), text, "the tool number is a variable")
                    if int(m.group(3)) == NULL_TOOL:
                        continue
                    mass, cog = self._data(src, m.start(), text, int(m.group(3)))
                else:
                    mass, cog = self._value(src, m.start(), text, m.group(1), m.group(2))
                out.append(_setting(src, m.start(), text, mass, cog))
        return out

    def _data(self, src, at, text, n: int):
        got = self.data.get(n)
        if got is None:
            raise _unread(src, at, text, f"LOAD_DATA[{n}] is declared in no file given (the controller "
                          "keeps it in $config.dat: give that with --references)")
        if isinstance(got, str):
            raise _unread(src, at, text, got)
        return got

    def _value(self, src, at, text, component, value):
        if component:
            raise _unread(src, at, text, "a component of $LOAD is set (the load is read from whole "
                          "assignments)")
        lit = _KRL_LITERAL.match(value.strip())
        if lit:
            if float(lit.group(1)) < 0:
                raise _unread(src, at, text, "M -1 is the controller's default load, not known here")
            return float(lit.group(1)), tuple(float(v) * MM for v in lit.groups()[1:])
        data = re.fullmatch(r"\s*LOAD_DATA\s*\[\s*(\d+)\s*\]\s*", value, re.IGNORECASE)
        if data:
            return self._data(src, at, text, int(data.group(1)))
        raise _unread(src, at, text, "the load is a variable or computed at run time")

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


# ----------------------------------------------------------------------------------------- FANUC
_FANUC_MASK = [re.compile(r"^\s*\d+:\s*!.*$", re.MULTILINE), re.compile(r"//[^\n]*")], []
_PAYLOAD = re.compile(r"\bPAYLOAD\s*\[\s*(?:GP1\s*:\s*)?([^\]:,]*)\s*(?:[:,][^\]]*)?\]", re.IGNORECASE)
_VA_FIELD = re.compile(r"\$PLST_GRP1\s*\[\s*(\d+)\s*\]\s*\.\s*\$(PAYLOAD(?:_[XYZ])?)\b[^=\n]*=\s*" + _NUM,
                       re.IGNORECASE)
SCHEDULE_COLUMNS = ("schedule", "payload_kg", "payload_x_cm", "payload_y_cm", "payload_z_cm")


class FanucLoads(LoadReader):
    """FANUC TP (module docstring): ``PAYLOAD[n]`` with the schedules the user gives."""

    def __init__(self, schedules: dict[int, Load] | None):
        self.schedules = schedules

    def settings(self, sources, references):
        out = []
        for src in sources:
            masked = mask(src.text, *_FANUC_MASK)
            for m in _PAYLOAD.finditer(masked):
                text = m.group(0)
                if not m.group(1).strip().isdigit():
                    raise _unread(src, m.start(), text, "the schedule number is a register or variable")
                n = int(m.group(1))
                if self.schedules is None:
                    raise _unread(src, m.start(), text, "the payload schedules live in the controller: give "
                                  "them with --payload-schedules (its SYSVARS.VA, or a CSV "
                                  f"{','.join(SCHEDULE_COLUMNS)})")
                if n not in self.schedules:
                    raise _unread(src, m.start(), text, f"payload schedule {n} is not in the schedules given "
                                  f"(they hold {sorted(self.schedules)})")
                load = self.schedules[n]
                out.append(_setting(src, m.start(), text, load[0], load[1:]))
        return out


def read_schedules(path: str | Path) -> dict[int, Load]:
    """FANUC payload schedules of motion group 1, the values ``PAYLOAD[n]`` selects.

    From the controller's SYSVARS.VA (``Field: $PLST_GRP1[n].$PAYLOAD ... = kg``,
    ``$PAYLOAD_X/_Y/_Z`` in cm in the faceplate frame) or a CSV with the header
    ``schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm``. A schedule with a mass <= 0
    (the factory's -9999 placeholder) is not set and left out.

    Parameters
    ----------
    path : str or path-like
        The SYSVARS.VA or the CSV.

    Returns
    -------
    dict of int to tuple of 4 floats
        Schedule number -> (kg, centre of mass x, y, z in metres in the flange frame tool0).

    Raises
    ------
    DataError
        An unreadable file, neither format, a schedule without a mass, or none set.

    Examples
    --------
    >>> from pathlib import Path
    >>> from robocal.programs import read_schedules
    >>> _ = Path("payloads.csv").write_text("schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm\\n"
    ...                                     "1,32,0,0,18\\n2,82,0,0,34\\n")
    >>> read_schedules("payloads.csv")[2]  # 82 kg, 34 cm out along the faceplate's z
    (82.0, 0.0, 0.0, 0.34)
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("latin-1")
    except OSError as exc:
        raise DataError(f"cannot read payload schedules {path}: {exc.strerror}") from None
    fields: dict[int, dict[str, float]] = {}
    if "$PLST_GRP1" in text.upper():
        for m in _VA_FIELD.finditer(text):
            fields.setdefault(int(m.group(1)), {})[m.group(2).upper()] = float(m.group(3))
    else:
        rows = list(csv.reader(io.StringIO(text)))
        header = [c.strip().lower() for c in rows[0]] if rows else []
        if tuple(header) != SCHEDULE_COLUMNS:
            raise DataError(f"{path.name}: not a SYSVARS.VA with $PLST_GRP1 nor a CSV with the header "
                            f"{','.join(SCHEDULE_COLUMNS)}")
        for k, row in enumerate(rows[1:], start=2):
            if not any(c.strip() for c in row):
                continue
            try:
                n, kg, x, y, z = (float(c) for c in row)
            except ValueError:
                raise DataError(f"{path.name}:{k}: expected 5 numbers ({','.join(SCHEDULE_COLUMNS)})") \
                    from None
            fields[int(n)] = {"PAYLOAD": kg, "PAYLOAD_X": x, "PAYLOAD_Y": y, "PAYLOAD_Z": z}
    out = {}
    for n, f in fields.items():
        if "PAYLOAD" not in f:
            raise DataError(f"{path.name}: payload schedule {n} has no mass ($PAYLOAD)")
        values = [f["PAYLOAD"], *(f.get(f"PAYLOAD_{c}", 0.0) * CM for c in "XYZ")]
        if not np.isfinite(values).all():
            raise DataError(f"{path.name}: payload schedule {n} has a value that is not a number")
        if values[0] > UNSET_KG:
            out[n] = tuple(values)
    if not out:
        raise DataError(f"{path.name}: no payload schedule with a mass > 0 kg")
    return out


# -------------------------------------------------------------------------------------- URScript
_UR_MASK = [re.compile(r"#[^\n]*")], [re.compile(r"\"[^\"\n]*\"|'[^'\n]*'")]
_UR_CALL = re.compile(r"\b(set_payload|set_target_payload|set_payload_mass|set_payload_cog)\s*\(([^()\n]*"
                      r"(?:\[[^\]\n]*\][^()\n]*)?)\)")
_UR_ARGS = re.compile(r"\s*" + _NUM + r"\s*(?:,\s*\[\s*" + _NUM + r"\s*,\s*" + _NUM + r"\s*,\s*" + _NUM
                      + r"\s*\]\s*)?(?:,.*)?")
_UR_COG = re.compile(r"\s*\[\s*" + _NUM + r"\s*,\s*" + _NUM + r"\s*,\s*" + _NUM + r"\s*\]\s*")


class URScriptLoads(LoadReader):
    """URScript (module docstring)."""

    def settings(self, sources, references):
        out = []
        for src in sources:
            masked = mask(src.text, *_UR_MASK)
            for m in _UR_CALL.finditer(masked):
                fn, args, text = m.group(1), m.group(2), m.group(0)
                if fn == "set_payload_cog":
                    c = _UR_COG.fullmatch(args)
                    if c is None:
                        raise _unread(src, m.start(), text, "the centre of gravity is not written as numbers")
                    out.append(_setting(src, m.start(), text, None, [float(v) for v in c.groups()]))
                    continue
                a = _UR_ARGS.fullmatch(args)
                if a is None or (fn == "set_payload_mass" and a.group(2) is not None):
                    raise _unread(src, m.start(), text, "the payload is not written as numbers")
                cog = None if a.group(2) is None else [float(v) for v in a.groups()[1:]]
                out.append(_setting(src, m.start(), text, float(a.group(1)), cog))
        return out


def reader_for(dialect: Dialect, tools: dict[str, np.ndarray], schedules: dict[int, Load] | None) \
        -> LoadReader:
    """The load reader of ``dialect`` (one that reads nothing for a dialect without load
    statements: INFORM, VAL3); ``tools``: the program's tool frames (RAPID payloads are given in
    the tool frame); ``schedules``: FANUC payload schedules (:func:`read_schedules`)."""
    if isinstance(dialect, RapidDialect):
        return RapidLoads(tools)
    if isinstance(dialect, KRLDialect):
        return KRLLoads()
    if isinstance(dialect, FanucDialect):
        return FanucLoads(schedules)
    if isinstance(dialect, URScriptDialect):
        return URScriptLoads()
    return LoadReader()
