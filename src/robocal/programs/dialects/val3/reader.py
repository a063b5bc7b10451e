"""Staubli VAL3 applications: a folder with the project (``.pjx``), programs (``.pgx``: XML whose
``<Code>`` holds the VAL3 code in CDATA) and data (``.dtx``).

Data (``.dtx``)::

    <Data name="pPick" access="public" xsi:type="array" type="pointRx" size="2">
      <Value key="0" x="412.5" y="-120" z="35.25" rx="180" rz="90" shoulder="lefty"
             elbow="epositive" wrist="wpositive" fatherId="fPallet[0]" />
      ...
    <Data name="fPallet" ... type="frame" size="1">
      <Value key="0" x="600" y="-200" z="50" rz="15" fatherId="world[0]" />
    <Data name="tGripper" ... type="tool" size="1">
      <Value key="0" z="180" fatherId="flange[0]" ioLink="valve1" />

x, y, z in mm, rx, ry, rz in deg: ``R = Rx(rx) Ry(ry) Rz(rz)`` (about the moving axes). An absent
coordinate is 0 (the controller's editor leaves zeros out); when a correction makes it non-zero,
the attribute is inserted after the coordinate before it (on the element that holds them). The
coordinates may also stand on an element inside the ``<Value>`` (the older CS8 layout); both are
read the same way. The s6.x layout of CS8 controllers (``programList`` / ``dataList``,
:mod:`~robocal.programs.dialects.val3.s6`) is read too. A point's
``fatherId`` chain of frames ends at ``world[0]`` (the robot's base); a tool's at ``flange[0]``.
Configuration (``shoulder`` lefty / righty, ``elbow`` epositive / enegative, ``wrist`` wpositive /
wnegative; ``ssame``, ``sfree``, ... or absent: any) selects the branch; VAL3 carries no turn data.

The motions ``movej``, ``movel`` and ``movec`` of the programs are read from the code: points
(``pPick``, ``pPick[1]``; ``pPick[i]`` with a run-time index reaches every element),
``appro(p, trsf)`` and ``compose(p, frame, trsf)`` with a trsf of the ``.dtx`` or a literal
``{x, y, z, rx, ry, rz}`` (a use of ``p``), program parameters (followed to every call's argument),
the tool (second argument; third of movec). Joint motions need nothing and are not counted: a
``movej`` to joints however they are declared (a ``jointRx`` datum, with values or without, a local
or parameter of a joint type, ``herej()``, a field of a user type whose ``.dtx`` is given or found
where the project's ``<Types>`` put it). Only the programs and data the ``.pjx`` lists are read
(the controller loads no other). ``here()``, points written by the code (an assignment, a field,
``sioGet``), locals, parameters no call (``call``, ``taskCreate``) gives, library data
(``lib:pPoint``) and ``appro`` / ``compose`` with a run-time trsf (a local trsf only ever set to a
literal of numbers is constant) are named. Only the numbers inside
the attribute values change (or an absent coordinate is added): the XML is never re-serialised.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.errors import DataError
from robocal.kinematics.transforms import make_transform
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.val3 import marker, s6, simulated
from robocal.programs.dialects.val3.campaign import val3_application
from robocal.programs.dialects.val3.configuration import (
    CONFIG_WORDS,
    ELBOW,
    SHOULDER,
    WRIST,
    StaubliConfig,
)
from robocal.programs.dialects.val3.loads import NoLoads
from robocal.programs.dialects.val3.project import declared_types, read_project
from robocal.programs.model import Program, Target
from robocal.programs.rotations import matrix_to_zyx
from robocal.programs.source import NUMBER_RE, Number, ProgramText, mask

COORDS = ("x", "y", "z", "rx", "ry", "rz")
_POSITION_MM = 1e-3
_ANGLE_DEG = 1e-4
WORLD, FLANGE = "world[0]", "flange[0]"
ROOTS = {"frame": WORLD, "tool": FLANGE}  # where a frame's / a tool's chain ends
MAX_CHAIN = 32  # frames in a fatherId chain (a longer one is a loop)
MAX_CALLS = 16  # calls a point parameter is followed through (deeper: named)

_COMMENT = re.compile(r"<!--.*?-->", re.DOTALL)
_DATA = re.compile(r"<Data\b([^>]*?)(/?)>")
_DATA_END = re.compile(r"</Data\s*>")
_VALUE = re.compile(r"<Value\b([^>]*?)(/?)>")
_VALUE_END = re.compile(r"</Value\s*>")
_INNER = re.compile(r"<\w+\b([^>]*?)/?>")
_ATTR = re.compile(r"([\w:]+)\s*=\s*\"([^\"]*)\"")
_PROGRAM = re.compile(r"<Program\b([^>]*?)>")
# a program's code: CDATA, or XML text (entities decoded: s6.decoded)
_CODE = re.compile(r"<Code\b[^>/]*>(?:\s*<!\[CDATA\[(.*?)\]\]>\s*|([^<]*))</Code>", re.DOTALL)
_LOCAL = re.compile(r"<(?:Local|Parameter)\b([^>]*?)/?>")
_STRING_OR_COMMENT = re.compile(r"\"[^\"\r\n]*\"|//[^\r\n]*")
_MOTION = re.compile(r"\b(movej|movel|movec)\s*\(")
# a call of a program: call NAME(...), or a task started on it: taskCreate "name", priority, NAME(...),
# taskCreateSync "name", period, overrun, NAME(...)
_CALL = re.compile(r"(?:\bcall\s+|\btaskCreate\s+(?:[^,\r\n]+,){2}\s*|"
                   r"\btaskCreateSync\s+(?:[^,\r\n]+,){3}\s*)([A-Za-z_]\w*)\s*\(")
_LIBRARY = re.compile(r"^\s*([A-Za-z_]\w*)\s*:\s*([A-Za-z_]\w*)")  # alias:name (a library's data)
# no two quantifiers over the same blanks next to each other (``\[\s*([^\]]*?)\s*\]`` backtracked in
# cubic time on a long blank run: the index is stripped by `_item`)
_ITEM = re.compile(r"^\s*([A-Za-z_]\w*)(?:\s*\[([^\]]*)\])?\s*$")
_LITERAL6 = re.compile(r"^\s*\{\s*" + r"\s*,\s*".join([f"({NUMBER_RE.pattern})"] * 6) + r"\s*\}\s*$")
_WRAPPER = re.compile(r"^\s*(appro|compose)\s*\((.*)\)\s*$", re.DOTALL)
OLD_TYPES = {"point": "pointRx", "joint": "jointRx"}  # the type names of older VAL3 versions
KNOWN_TYPES = ("pointRx", "frame", "tool", "trsf", "jointRx")  # the data read from a .dtx
JOINT_TYPES = ("joint", "jointRx", "jointRs")  # a movej to one of these is no Cartesian motion
_ASSIGNED = re.compile(r"(?<![\w.])([A-Za-z_]\w*)(?:\s*\[[^\]]*\])?((?:\s*\.\w+)*)\s*=(?!=)")  # name[i].f =
_FIELD = re.compile(r"^\s*([A-Za-z_]\w*)(?:\s*\[[^\]]*\])?\s*\.\s*([A-Za-z_]\w*)\s*$")


@dataclass
class Datum:
    """One ``<Value>`` of a ``<Data>``: its type, the coordinates (Number, or a zero-length
    Number where the attribute is absent), config words and spans, fatherId."""

    name: str
    type: str
    source: ProgramText
    offset: int
    numbers: list[Number]
    inserts: dict[int, str] = field(default_factory=dict)  # offset of an absent coordinate -> its name
    config: list[tuple[str, int, int] | None] = field(default_factory=list)  # (word, start, end)
    father: str = ""
    joints: np.ndarray | None = None


def _attrs(text: str, start: int, end: int,
           src: ProgramText | None = None) -> dict[str, tuple[str, int, int]]:
    """name -> (value, start, end of the value) of the attributes in ``text[start:end]``; with
    ``src``, an attribute given twice in the element is a DataError (XML forbids it, and which copy
    a reader takes differs: correcting one would leave the other)."""
    out: dict[str, tuple[str, int, int]] = {}
    for m in _ATTR.finditer(text, start, end):
        if src is not None and m.group(1) in out:
            raise DataError(f"{src.where(m.start())}: attribute {m.group(1)} given twice in one element "
                            f"(first at line {src.line_of(out[m.group(1)][1])}): keep one")
        out[m.group(1)] = (m.group(2), m.start(2), m.end(2))
    return out


def _add(out: dict[str, Datum], datum: Datum) -> None:
    """Add ``datum`` to ``out``; a value named twice (two ``<Value key="0">`` of one datum, or two
    data of one name) is a DataError naming both lines: correcting one copy would leave the other."""
    first = out.get(datum.name)
    if first is not None:
        src = datum.source
        where = src.line_of(first.offset) if first.source is src else first.source.where(first.offset)
        raise DataError(f"{src.where(datum.offset)}: {datum.name} is given twice (first at "
                        f"{'line ' if first.source is src else ''}{where}): give each value once")
    out[datum.name] = datum


def _closing(text: str, start: int, close: re.Pattern, opening: re.Pattern, end: int | None = None) \
        -> re.Match | None:
    """The closing tag ``close`` of the element opened before ``start``, searched before the next
    element ``opening`` and ``end`` (a missing one must not take the next element's close, and with
    it the next element's values)."""
    end = len(text) if end is None else end
    following = opening.search(text, start, end)
    return close.search(text, start, following.start() if following else end)


def _read_data(src: ProgramText) -> dict[str, Datum]:
    """Every element of every ``<Data>`` of a .dtx: 'name[k]' -> Datum (s6.x layout: its sections)."""
    text = mask(src.text, [_COMMENT])
    if s6.is_s6(text):
        return _read_data_s6(src, text)
    out: dict[str, Datum] = {}
    for d in _DATA.finditer(text):
        head = _attrs(text, d.start(1), d.end(1), src)
        if "name" not in head or "type" not in head:
            raise DataError(f"{src.where(d.start())}: a <Data> without name or type")
        name, kind = head["name"][0], head["type"][0]
        if d.group(2) == "/" and kind in ROOTS:  # no values: every element at its defaults (identity)
            size = head.get("size", ("1",))[0]
            for k in range(int(size) if size.isdigit() and len(size) < 6 else 1):
                _add(out, _datum(src, f"{name}[{k}]", kind, d.start(), {}, d.end(), ""))
        if d.group(2) == "/":
            continue  # no values (a point without values is no taught target)
        stop = _closing(text, d.end(), _DATA_END, _DATA)
        if stop is None:
            raise DataError(f"{src.where(d.start())}: <Data name=\"{name}\"> is not closed: no </Data> "
                            "before the next <Data> or the end of the file")
        if OLD_TYPES.get(kind, kind) not in KNOWN_TYPES:
            continue  # a type with no pose
        for v in _VALUE.finditer(text, d.end(), stop.start()):
            attrs = _attrs(text, v.start(1), v.end(1), src)
            if "key" not in attrs:
                raise DataError(f"{src.where(v.start())}: a <Value> of {name} without key")
            anchor = attrs["key"][2] + 1  # an absent coordinate goes right after the one before it
            if v.group(2) != "/":
                close = _closing(text, v.end(), _VALUE_END, _VALUE, stop.start())
                if close is None:
                    raise DataError(f"{src.where(v.start())}: <Value> of {name} is not closed")
                anchor = _inner(text, v.end(), close.start(), attrs, anchor, src)
            key = f"{name}[{attrs['key'][0]}]"
            _add(out, _datum(src, key, kind, v.start(), attrs, anchor, attrs.get("fatherId", ("",))[0]))
    return out


def _inner(text: str, start: int, end: int, attrs: dict, anchor: int, src: ProgramText) -> int:
    """Add the attributes of the elements inside a value (the older layouts: coordinates on an
    inner element) to ``attrs``; the anchor of an absent coordinate: right after the name of
    the element that holds the coordinates."""
    for inner in _INNER.finditer(text, start, end):
        got = _attrs(text, inner.start(1), inner.end(1), src)
        if any(c in got for c in COORDS):
            anchor = inner.start(1)
        for k, val in got.items():
            attrs.setdefault(k, val)
    return anchor


def _read_data_s6(src: ProgramText, text: str) -> dict[str, Datum]:
    """The pose and joint data of an s6.x .dtx (:mod:`robocal.programs.dialects.val3.s6`)."""
    out: dict[str, Datum] = {}
    for element, name, start, end, body, closed in s6.data_items(text):
        if not closed:
            raise DataError(f"{src.where(start)}: <{element} name=\"{name}\"> is not closed: no </{element}> "
                            f"before the next <{element}> or the end of its section")
        if element in ROOTS and body == end:  # no values: at its defaults (identity)
            _add(out, _datum(src, f"{name}[0]", element, start, {}, end, ""))
        if element not in s6.TYPES or body == end:
            continue
        father = ""
        if element in s6.FATHER:
            f = re.search(rf"<{s6.FATHER[element]}\b([^>]*?)/?>", text[body:end])
            got = {} if f is None else dict(_ATTR.findall(f.group(1)))
            if got.get("name"):
                alias = f"{got['alias']}:" if got.get("alias") else ""
                father = f"{alias}{got['name']}[{got.get('fatherIndex', '0')}]"
        tag = s6.VALUE_ELEMENT[element]
        value, close = re.compile(rf"<{tag}\b([^>]*?)(/?)>"), re.compile(rf"</{tag}\s*>")
        for v in value.finditer(text, body, end):
            attrs = _attrs(text, v.start(1), v.end(1), src)
            if "index" not in attrs:
                raise DataError(f"{src.where(v.start())}: a <{tag}> of {name} without index")
            anchor = attrs["index"][2] + 1
            if v.group(2) != "/":
                stop = _closing(text, v.end(), close, value, end)
                if stop is None:
                    raise DataError(f"{src.where(v.start())}: <{tag}> of {name} is not closed")
                anchor = _inner(text, v.end(), stop.start(), attrs, anchor, src)
            key = f"{name}[{attrs['index'][0]}]"
            if element != "joint" and not any(c in attrs for c in COORDS):
                # s6 keeps the coordinates on an inner element (<tpValue .../>): without one there
                # is nowhere safe to write a corrected value (not on <valuePoint> itself)
                raise DataError(f"{src.where(v.start())}: <{tag}> of {key} holds no coordinates element "
                                "(such as <tpValue x=... />): save the data again with the controller "
                                "or Staubli Robotics Suite")
            _add(out, _datum(src, key, s6.TYPES[element], v.start(), attrs, anchor, father))
    return out


def _not_a_number(value: str) -> str:
    """Why an attribute's value is no coordinate or joint value ("" when it is one)."""
    if not NUMBER_RE.fullmatch(value):
        return "not a number"
    return "" if math.isfinite(float(value)) else "not a finite number"


def _datum(src: ProgramText, key: str, kind: str, offset: int, attrs: dict, after: int, father: str) -> Datum:
    """One value: ``after`` is where an absent first coordinate is inserted."""
    kind = OLD_TYPES.get(kind, kind)
    if not father and kind in ROOTS and key != ROOTS[kind]:
        father = ROOTS[kind]  # fatherId left out: the default, world[0] for a frame, flange[0] for a tool
    datum = Datum(key, kind, src, offset, [], father=father)
    if kind in ("pointRx", "frame", "tool", "trsf"):
        for c in COORDS:
            if c in attrs:
                val, a, b = attrs[c]
                if _not_a_number(val):
                    raise DataError(f"{src.where(a)}: {key}: {c}=\"{val}\" is {_not_a_number(val)}")
                datum.numbers.append(Number(a, b, val))
                after = b + 1
            else:
                datum.numbers.append(Number(after, after, "0"))
                datum.inserts[after] = c
    if kind == "pointRx":
        for word, values in CONFIG_WORDS:
            got = attrs.get(word)
            datum.config.append(None if got is None or got[0] not in values else got)
    if kind == "jointRx":
        joints = [attrs.get(f"j{i}", ("0",))[0] for i in range(1, 7)]
        bad = next((f"j{i}=\"{v}\" is {why}" for i, v in enumerate(joints, 1) if (why := _not_a_number(v))),
                   None)
        if bad:
            raise DataError(f"{src.where(offset)}: {key}: {bad}")
        datum.joints = np.deg2rad([float(v) for v in joints])
    return datum


def _chain(data: dict[str, Datum], start: str, root: str, what: str, where: str,
           supplied: dict) -> np.ndarray:
    """The pose of ``start`` in ``root`` through the fatherId chain (a frame or tool given on the
    command line overrides the file's)."""
    T, name, seen = np.eye(4), start, 0
    while name != root:
        if name in supplied:
            return supplied[name] @ T
        d = data.get(name)
        if d is None or d.type != what or seen > MAX_CHAIN:
            raise DataError(f"{where}: {what} {name} is not declared in the .dtx files given (its chain must "
                            f"end at {root})")
        T = Val3Dialect.pose_of(d) @ T
        name, seen = d.father, seen + 1
    return T


class Val3Dialect(Dialect):
    name = "Staubli VAL3"
    key = "val3"
    campaign_rank = 5
    vendor = "Staubli"
    signature = r"staubli\.com/robotics/VAL3|" + s6.SIGNATURE
    suffixes = (".pgx", ".dtx", ".pjx")
    scheme = StaubliConfig()
    frame_help = "x,y,z in mm and rx,ry,rz in deg (R = Rx Ry Rz), as in the .dtx"

    def folder_files(self, folder):
        return application_files(folder)

    def load_reader(self, tools, schedules):
        return NoLoads()

    def campaign_files(self, joints, robot, path, **options):
        files = val3_application(np.rad2deg(joints), path.name, **options)
        return {str(path / file): text for file, text in files.items()}

    def campaign_paths(self, path, procedure):
        if path.exists() and not path.is_dir():
            raise DataError(f"--val3 {path}: not a folder (a VAL3 application is a folder)")
        if not path.exists() and not path.resolve().parent.is_dir():
            raise DataError(f"--val3 {path}: its parent folder does not exist")
        names = val3_application([[0.0] * 6], path.name, procedure=procedure)
        return [str(path / name) for name in names] if path.is_dir() else []

    def campaign_folder(self, path):
        return path

    def mark(self, text, body, note):
        return marker.mark(text, body, note)

    def test_program(self, folder, nominal, q, tool, frame, name, variables=False):
        return simulated.write_test_program(self, folder, nominal, q, tool, frame, name, variables)

    @staticmethod
    def pose_of(d: Datum) -> np.ndarray:
        return Val3Dialect().to_pose(np.array([[n.value for n in d.numbers]]))[0]

    def to_pose(self, values):
        values = np.asarray(values, float)
        R = Rotation.from_euler("XYZ", values[:, 3:6], degrees=True).as_matrix()
        return make_transform(R, values[:, :3] * 1e-3)

    def from_pose(self, T, old):
        old = np.asarray(old, float)
        # R = Rx(a) Ry(b) Rz(c) is the transpose of Rz(-c) Ry(-b) Rx(-a): the ZYX reader nearest -old
        zyx = matrix_to_zyx(np.swapaxes(T[:, :3, :3], 1, 2), -old[:, [5, 4, 3]])
        return np.hstack([T[:, :3, 3] * 1e3, -zyx[:, [2, 1, 0]]])

    def resolutions(self):
        return np.array([_POSITION_MM] * 3 + [_ANGLE_DEG] * 3)

    def number_edit(self, target: Target, num: Number, text: str) -> str:
        if num.end != num.start or not target.config_spans:
            return text
        k = next(i for i, n in enumerate(target.numbers) if n is num)  # several may be absent at one place
        return f" {COORDS[k]}=\"{text}\""

    def config_edits(self, target, new):
        spans = target.config_spans[0]
        out = {}
        for (_, values), got, v in zip(CONFIG_WORDS, spans, new, strict=True):
            text = next(w for w, k in values.items() if k == int(v))
            if got is not None and got[0] != text:
                out[(got[1], got[2])] = text
        return out

    def name_key(self, name):
        """``fPart`` is the datum's first element ``fPart[0]``, as in the code."""
        name = "".join(name.split())
        return name if "[" in name else f"{name}[0]"

    def parse(self, sources, frames, tools, references=()):
        frames = {self.name_key(k): v for k, v in frames.items()}
        tools = {self.name_key(k): v for k, v in tools.items()}
        prog = Program([], frames={WORLD: np.eye(4), **frames}, tools={FLANGE: np.eye(4), **tools},
                       declared_tools={FLANGE: np.eye(4)})  # and each motion's tool from the .dtx alone
        projects = [read_project(s.path) for s in sources if s.path.suffix.lower() == ".pjx"]
        sources = _in_projects(sources, projects, prog.warnings)
        data: dict[str, Datum] = {}
        types: dict[str, str] = {}
        for src in [*sources, *references]:
            if src.path.suffix.lower() == ".dtx":
                data.update(_read_data(src))
                types.update(declared_types(src.text))
        programs = [s for s in sources if s.path.suffix.lower() == ".pgx"]
        if not programs:
            prog.warnings.append("no .pgx program given: give the application's folder or its .pgx files")
        targets: dict[str, Target] = {}
        ctx = _Context(data, [r for src in programs for r in _routines(src)])
        ctx.types, ctx.fields = types, _type_fields(projects, [*sources, *references])
        ctx.libraries = {alias: {k: v for dtx in p.data_at(where) for k, v in _declared_in(dtx).items()}
                         for p in projects for alias, where in p.libraries.items()}
        prog.declared_frames = _declared_frames(data)
        for r in ctx.routines.values():
            _program_motions(r, ctx, prog, targets, frames)
        return prog


def _declared_frames(data: dict[str, Datum]) -> dict[str, np.ndarray]:
    """The frames the .dtx files declare, each in world through its fatherId chain (a chain they do
    not close is left out: a given frame is the only one), by name: what a ``--frame`` replaces."""
    out = {}
    for name, d in data.items():
        if d.type == "frame":
            try:
                out[name] = _chain(data, name, WORLD, "frame", d.source.where(d.offset), {})
            except DataError:
                continue
    return out


def _declared_in(dtx: Path) -> dict[str, str]:
    """:func:`declared_types` of a library's or user type's .dtx found on the disk (one it cannot
    read declares nothing: what it would tell is then named, not guessed)."""
    try:
        return declared_types(ProgramText(dtx).text)
    except (DataError, OSError):
        return {}


def _in_projects(sources: list[ProgramText], projects: list, warnings: list[str]) -> list[ProgramText]:
    """The program and data files a ``.pjx`` given lists (the controller loads no other): a .pgx
    or .dtx beside it that no project lists is left out, with a warning (its bytes unchanged). A
    project that lists no program (unreadable) filters nothing."""
    projects = [p for p in projects if p.programs]
    if not projects:
        return sources
    listed = set().union(*(p.programs | p.data for p in projects))
    out = []
    for src in sources:
        if src.path.suffix.lower() in (".pgx", ".dtx") and src.path.name.lower() not in listed:
            names = ", ".join(p.path.name for p in projects)
            warnings.append(f"{src.path.name} is not in the project ({names}): the controller does not load "
                            "it; its motions and data are not read")
            continue
        out.append(src)
    return out


def _type_fields(projects: list, files: list[ProgramText]) -> dict[str, dict[str, str]]:
    """User type -> its fields' VAL3 types: from the type's own .dtx, given or found on the disk the
    project names (:class:`~robocal.programs.dialects.val3.project.Project`)."""
    out: dict[str, dict[str, str]] = {}
    for p in projects:
        for name, where in p.types.items():
            stem = Path(where.replace("\\", "/")).stem.lower()
            given = [f.path for f in files if f.path.suffix.lower() == ".dtx" and f.path.stem.lower() == stem]
            for dtx in given or p.type_data(name):
                fields = (_declared_in(dtx) if dtx not in given else
                          declared_types(next(f.text for f in files if f.path == dtx)))
                out.setdefault(name, {}).update(fields)
    return out


def _target(d: Datum, frame: str, tool: str) -> Target:
    config = np.array([-1 if c is None else {**SHOULDER, **ELBOW, **WRIST}[c[0]] for c in d.config])
    if (config < 0).all():  # ssame / sfree / absent throughout: the solution nearest the joints before
        config = None
    return Target(d.source, d.offset, d.name, d.numbers, frame=frame, tool=tool, config=config,
                  config_spans=(d.config, d.inserts))


def _split_args(text: str) -> list[str]:
    """Top-level comma-separated arguments of ``text``."""
    out, depth, cur = [], 0, []
    for ch in text:
        if ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        if ch == "," and depth == 0:
            out.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    out.append("".join(cur))
    return out


def _call_args(code: str, open_at: int) -> tuple[list[str], int] | None:
    """Arguments of the call whose '(' is at ``open_at``, and the offset after ')'."""
    depth = 0
    for i in range(open_at, len(code)):
        if code[i] == "(":
            depth += 1
        elif code[i] == ")":
            depth -= 1
            if depth == 0:
                return _split_args(code[open_at + 1:i]), i + 1
    return None


@dataclass
class _Routine:
    """One ``<Program>``: its name, parameters in order, locals and parameters -> type, its code."""

    name: str
    params: list[str]
    kinds: dict[str, str]
    src: ProgramText
    base: int  # the code's offset in the file
    text: str  # the code as the controller reads it (s6: entities decoded), at the file's offsets
    writes: dict[str, str] = field(default_factory=dict)  # local -> why it is no constant ('' : it is)
    set_at: dict[str, str] = field(default_factory=dict)  # local -> where the code first sets it

    @cached_property
    def code(self) -> str:
        """The code with comments blanked and strings masked (:func:`_code`), computed once."""
        return _code(self)


@dataclass
class _Context:
    """The application: its data, programs by name, what the code writes at run time (a point any
    program writes is a run-time point in all of them) and the calls of each program ``(caller,
    arguments, offset)``."""

    data: dict
    types: dict[str, str] = field(default_factory=dict)  # every data name of the .dtx -> its type
    fields: dict[str, dict[str, str]] = field(default_factory=dict)  # user type -> field -> type
    libraries: dict[str, dict[str, str]] = field(default_factory=dict)  # library alias -> data -> type
    routines: dict[str, _Routine] = field(default_factory=dict)
    written: dict[str, str] = field(default_factory=dict)
    calls: dict[str, list[tuple[_Routine, list[str], int]]] = field(default_factory=dict)

    def __init__(self, data: dict, routines: list[_Routine]):
        self.data, self.routines, self.written, self.calls = data, {r.name: r for r in routines}, {}, {}
        self.types, self.fields, self.libraries = {}, {}, {}
        for r in routines:
            code = r.code
            for name, (how, at) in _written(code).items():
                self.written.setdefault(name, f"{how} ({r.src.where(r.base + at)})")
            for m in _CALL.finditer(code):
                args = _call_args(code, m.end() - 1)
                if args is not None:
                    self.calls.setdefault(m.group(1), []).append((r, args[0], r.base + m.start()))


def _routines(src: ProgramText) -> list[_Routine]:
    """The ``<Program>`` blocks of a .pgx (a file may hold several; s6.x: ``<program>``)."""
    text, out, last = src.text, [], 0
    if s6.is_s6(text):
        return [_Routine(name or src.path.stem, params, kinds, src, base, code)
                for name, params, kinds, base, code in s6.programs(text)]
    for code_m in _CODE.finditer(text):
        header = text[last:code_m.start()]
        last = code_m.end()
        heads = list(_PROGRAM.finditer(header))
        name = _attrs(header, heads[-1].start(1), heads[-1].end(1)).get("name", ("",))[0] if heads else ""
        decl = [_attrs(header, m.start(1), m.end(1)) for m in _LOCAL.finditer(header)]
        params = [a["name"][0] for m, a in zip(_LOCAL.finditer(header), decl, strict=True)
                  if "name" in a and m.group(0).startswith("<Parameter")]
        kinds = {a["name"][0]: a.get("type", ("",))[0] for a in decl if "name" in a}
        if code_m.group(1) is not None:
            out.append(_Routine(name or src.path.stem, params, kinds, src, code_m.start(1), code_m.group(1)))
        else:
            out.append(_Routine(name or src.path.stem, params, kinds, src, code_m.start(2),
                                s6.decoded(code_m.group(2))))
    return out


def _code(r: _Routine) -> str:
    """A program's code with comments blanked and strings masked (offsets kept), in one pass: a
    ``//`` inside a string is no comment, a quote inside a comment opens no string."""

    def one(m: re.Match) -> str:
        s = m.group()
        if s.startswith("//"):
            return " " * len(s)
        return s[0] + "_" * (len(s) - 2) + s[-1]

    return _STRING_OR_COMMENT.sub(one, r.text)


def _program_motions(r: _Routine, ctx: _Context, prog: Program, targets: dict, frames: dict) -> None:
    """The motions of one program's code: its points (and the tool) as targets, or named."""
    src, data, kinds, written = r.src, ctx.data, r.kinds, ctx.written
    base = r.base
    code = r.code
    for m in _MOTION.finditer(code):
        call = _call_args(code, m.end() - 1)
        at = base + m.start()
        instr = m.group(1)
        if call is None:
            raise DataError(f"{src.where(at)}: {instr}( is not closed")
        args = call[0]
        points = args[:2] if instr == "movec" else args[:1]
        tool_arg = args[2] if instr == "movec" and len(args) > 2 else args[1] if len(args) > 1 else ""
        if all(_value_type(p, r, ctx) in JOINT_TYPES for p in points):
            continue  # a joint motion: no correction
        acc = prog.motion(src, at, instr)
        tool, why = _tool(tool_arg, data, kinds, written, prog.tools, src.where(at))
        _tool(tool_arg, data, kinds, written, prog.declared_tools, src.where(at))  # from the .dtx alone
        for p in points:
            label = " ".join(p.split())
            found, reason = _points(p, r, ctx)
            if reason or why:
                prog.skip(src.where(at), instr, reason or why, acc, label)
                continue
            for d in found:
                frame = d.father or WORLD
                key = d.name
                if frame not in prog.frames:
                    try:
                        prog.frames[frame] = _chain(data, frame, WORLD, "frame", src.where(at), frames)
                    except DataError as exc:
                        prog.skip(src.where(at), instr, str(exc).split(": ", 1)[1], acc, label)
                        break
                fw = _frame_written(frame, data, written)
                if fw:
                    prog.skip(src.where(at), instr, fw, acc, label)
                    break
                t = targets.get(key)
                if t is None:
                    t = targets[key] = _target(d, frame, tool)
                prog.use(t, tool, frame, src.where(at), key, "frame", (src.path, at), acc)


def _value_type(expr: str, r: _Routine, ctx: _Context) -> str:
    """The VAL3 type of a motion's argument (a local, a parameter, a datum of the .dtx, a field of
    a user type whose data are known, ``herej()``), '' when not known."""
    m = _ITEM.match(expr)
    if m:
        return r.kinds.get(m.group(1)) or ctx.types.get(m.group(1), "")
    f = _FIELD.match(expr)
    if f:
        owner = r.kinds.get(f.group(1)) or ctx.types.get(f.group(1), "")
        return ctx.fields.get(owner, {}).get(f.group(2), "")
    lib = _LIBRARY.match(expr)
    if lib:
        return ctx.libraries.get(lib.group(1), {}).get(lib.group(2), "")
    return "jointRx" if re.match(r"\s*herej\s*\(", expr) else ""


def _written(code: str) -> dict[str, tuple[str, int]]:
    """Names the code writes at run time (assignment, a field, sioGet) -> (how, offset in the code)."""
    out = {}
    for m in _ASSIGNED.finditer(code):
        fields = "".join(m.group(2).split())
        how = f"{m.group(1)}{fields} is assigned in the program at run time"
        out.setdefault(m.group(1), (how, m.start()))
    for m in re.finditer(r"\bsioGet\s*\(\s*[^,]+,\s*([A-Za-z_]\w*)", code):
        out.setdefault(m.group(1), (f"{m.group(1)} is received at run time (sioGet)", m.start()))
    return out


def _points(expr: str, r: _Routine, ctx: _Context, depth: int = 0) -> tuple[list[Datum], str]:
    """The pointRx data an argument of program ``r`` reaches, or why it cannot be followed; a
    parameter is followed to the arguments of every call of ``r`` (``depth``: calls followed)."""
    data, kinds, written = ctx.data, r.kinds, ctx.written
    w = _WRAPPER.match(expr)
    if w:
        args = _split_args(w.group(2))
        func = w.group(1)
        if func == "appro" and len(args) == 2 or func == "compose" and len(args) == 3:
            for extra in args[1:]:
                why = _constant(extra, r, ctx, "frame" if func == "compose" and extra is args[1] else "trsf")
                if why:
                    return [], f"{func}(...) with {why}"
            return _points(args[0], r, ctx, depth)
        return [], f"{func}(...) with {len(args)} arguments"
    m = _ITEM.match(expr)
    f = _FIELD.match(expr)
    if not m and f:
        owner = kinds.get(f.group(1)) or ctx.types.get(f.group(1), "")
        if owner in ctx.fields:
            return [], f"{f.group(1)}.{f.group(2)} is a field of {f.group(1)} ({owner}): set at run time"
        return [], (f"{f.group(1)}.{f.group(2)} is a field of {f.group(1)} ({owner or 'type not declared'}) "
                    "whose type data are not in the files given: give its .dtx with --references")
    lib = _LIBRARY.match(expr)
    if not m and lib:
        return [], f"{' '.join(expr.split())} is data of library {lib.group(1)}, not in these files"
    if not m:
        call = re.match(r"\s*([A-Za-z_]\w*)\s*\(", expr)
        if call:
            return [], f"computed at run time by {call.group(1)}()"
        return [], "an expression this filter does not follow"
    name, index = m.group(1), None if m.group(2) is None else m.group(2).strip()
    if name in r.params and index is None and name not in written:
        return _through_calls(name, r, ctx, depth)
    if name in kinds:
        what = "parameter" if name in r.params else "local"
        if name not in r.set_at:
            at = re.search(rf"(?<![\w.]){name}(?:\s*\[[^\]]*\])?(?:\s*\.\w+)*\s*=(?!=)", r.code)
            r.set_at[name] = f" ({r.src.where(r.base + at.start())})" if at else ""
        where = r.set_at[name]
        return [], f"{name} is a {what} of {r.name} ({kinds[name] or 'no type'}): set at run time{where}"
    if name in written:
        return [], written[name]
    if index is None or re.fullmatch(r"\d+", index):
        d = data.get(f"{name}[{int(index or 0)}]")
        declared = ctx.types.get(name, "")
        if d is None and declared in ("pointRx", "point"):
            return [], f"{name}[{int(index or 0)}] has no values in the .dtx (all 0): no taught target"
        if d is None and declared:
            return [], f"{name} is a {declared}, not a pointRx"
        if d is None:
            return [], f"{name}[{int(index or 0)}] is not declared in the .dtx files given"
        if d.type != "pointRx":
            return [], f"{name} is a {d.type}, not a pointRx"
        return [d], ""
    elements = [d for k, d in data.items() if k.startswith(name + "[") and d.type == "pointRx"]
    if not elements:
        return [], f"{name}[{index}]: no pointRx {name} in the .dtx files given"
    return elements, ""  # a run-time index: every element


def _through_calls(name: str, r: _Routine, ctx: _Context, depth: int) -> tuple[list[Datum], str]:
    """The points parameter ``name`` of ``r`` receives from every call of ``r``."""
    calls = ctx.calls.get(r.name, [])
    if not calls:
        return [], f"{name} is a parameter of {r.name} that no call in these files gives"
    if depth >= MAX_CALLS:
        return [], f"{name} is passed through more than {MAX_CALLS} calls"
    k = r.params.index(name)
    found: list[Datum] = []
    for caller, args, at in calls:
        where = caller.src.where(at)
        if k >= len(args):
            return [], f"{name}: the call of {r.name} at {where} does not give it"
        got, why = _points(args[k], caller, ctx, depth + 1)
        if why:
            return [], f"{name} is a parameter: the call at {where} passes {' '.join(args[k].split())}: {why}"
        found += [d for d in got if all(d is not e for e in found)]
    return found, ""


def _constant(expr: str, r: _Routine, ctx: _Context, what: str) -> str:
    """'' when ``expr`` (an argument of program ``r``) is a constant trsf / frame, else why not: a
    literal of numbers, a datum of the .dtx the code never writes (one declared without values
    is zeros), a local only ever set to a literal of numbers (or never: zeros)."""
    text = " ".join(expr.split())
    if _LITERAL6.match(expr):
        return ""
    m = _ITEM.match(expr)
    if not m:
        return f"a {what} computed at run time ({text})"
    name, index = m.group(1), None if m.group(2) is None else m.group(2).strip()
    if index is not None and not re.fullmatch(r"\d+", index):
        return f"a {what} chosen at run time ({text})"
    if name in r.params:
        return f"a {what} passed at run time ({text} is a parameter of {r.name})"
    if name in r.kinds:
        why = _local_writes(name, r)
        if r.kinds[name] == what and not why:
            return ""
        return f"a run-time {what} ({text} {why or 'is a ' + r.kinds[name]})"
    if name in ctx.written:
        return f"a run-time {what} ({ctx.written[name]})"
    declared = ctx.types.get(name, "") or ("frame" if name == "world" else "")  # world: built in
    if declared == what:
        return ""
    return f"an unknown {what} {name}" if not declared else f"{name}, a {declared}, not a {what}"


def _local_writes(name: str, r: _Routine) -> str:
    """'' when program ``r`` only ever sets its local ``name`` to a literal of numbers (or never),
    else where it sets it otherwise (a field, an expression, a call that may write it)."""
    if name not in r.writes:
        r.writes[name] = _first_write(name, r)
    return r.writes[name]


def _first_write(name: str, r: _Routine) -> str:
    code = r.code
    for m in re.finditer(rf"(?<![\w.]){name}\s*(?:\[[^\]]*\])?\s*((?:\.\w+)*)\s*=(?!=)([^\r\n]*)", code):
        if m.group(1) or not _LITERAL6.match(m.group(2)):
            return f"is set at run time ({r.src.where(r.base + m.start())})"
    for m in _CALL.finditer(code):
        args = _call_args(code, m.end() - 1)
        if args is not None and any(re.fullmatch(rf"\s*{name}\s*(?:\[[^\]]*\])?\s*", a) for a in args[0]):
            return f"is passed to {m.group(1)}() at {r.src.where(r.base + m.start())}, which may set it"
    return ""


def _tool(expr: str, data: dict, kinds: dict, written: dict, tools: dict, where: str) -> tuple[str, str]:
    """(tool key, '') or ('', why)."""
    m = _ITEM.match(expr)
    lib = _LIBRARY.match(expr)
    if not m and lib:
        return "", f"the tool {' '.join(expr.split())} is data of library {lib.group(1)}, not in these files"
    if not m:
        return "", f"the tool {' '.join(expr.split()) or '(none)'} is computed at run time"
    name = m.group(1)
    if name in kinds:
        return "", f"the tool {name} is a local or parameter: set at run time"
    if name in written:
        return "", f"the tool {name} is changed at run time: {written[name]}"
    index = None if m.group(2) is None else m.group(2).strip()
    if index is not None and not re.fullmatch(r"\d+", index):
        return "", f"the tool {name}[{index}] is chosen at run time"
    key = f"{name}[{int(index or 0)}]"
    if key == FLANGE or name == "flange":
        return FLANGE, ""
    moved = _frame_written(key, data, written, "tool")
    if moved:
        return "", f"the tool {name}: {moved}"
    if key in tools:
        return key, ""
    try:
        tools[key] = _chain(data, key, FLANGE, "tool", where, tools)
    except DataError as exc:
        return "", str(exc).split(": ", 1)[1]
    return key, ""


def _frame_written(frame: str, data: dict, written: dict, what: str = "frame") -> str:
    """Why the pose of ``frame`` (a frame, or a tool: ``what``) changes at run time: the code
    writes it or one of its fathers; '' when it does not."""
    name = frame
    for _ in range(MAX_CHAIN):
        if name in (WORLD, FLANGE) or name not in data:
            return ""
        base = name.split("[")[0]
        if base in written:
            return f"its {what} {base} is changed at run time: {written[base]}"
        name = data[name].father
    return ""


def application_files(folder: Path) -> list[Path]:
    """The .pjx, .pgx and .dtx files of an application folder."""
    files = sorted(p for p in Path(folder).iterdir() if p.suffix.lower() in Val3Dialect.suffixes)
    if not files:
        raise DataError(f"{folder}: no .pjx, .pgx or .dtx file: not a VAL3 application folder")
    return files
