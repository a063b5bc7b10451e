"""Yaskawa INFORM jobs (.JBI, as the teach pendant saves them) and the global position variables of
the controller's ``VAR.DAT``.

A job::

    /JOB
    //NAME WELD_A
    //POS
    ///NPOS 3,0,0,0,0,0          C, BC, EC, P, BP, EX positions in //POS
    ///USER 2
    ///TOOL 1
    ///POSTYPE USER             PULSE (joints, encoder pulses), BASE, ROBOT or USER
    ///RECTAN                   Cartesian: X, Y, Z (mm), Rx, Ry, Rz (deg)
    ///RCONF 1,0,0,0,0,0,0,0    the configuration ("form") of the positions that follow
    C00000=1012.500,-155.000,320.000,180.0000,0.0000,0.0000
    //INST
    ///DATE 2024/03/01 10:12
    ///ATTR SC,RW
    ///GROUP1 RB1
    NOP
    MOVL C00000 V=120.0 PL=0
    END

The ``///`` header lines are a state: each position takes the TOOL, USER, POSTYPE and RCONF last
set above it. Rx, Ry, Rz are fixed-axis XYZ angles, ``R = Rz(Rz) Ry(Ry) Rx(Rx)``. RCONF (see
:class:`YaskawaConfig`): flip, arm, front/back and the ``< 180`` flags of R, T and S; a form that
the correction must change is written as a ``///RCONF`` line before the position (and the old one
restored after it). ROBOT positions are in the robot's base frame; BASE positions too (a job
without base axes: the base and robot coordinates coincide); USER positions in the user frame
``///USER n``. Tool and user-frame values live in the controller: ``--tool n=X,Y,Z,Rx,Ry,Rz``,
``--frame n=...`` (mm, deg), or the user frames of the controller's UFRAME.CND and the tools of its
TOOL.CND given as references (:func:`user_frames`,
:mod:`robocal.programs.dialects.inform.tool_file`; ``--tool`` and ``--frame`` take precedence); tool 0
without data is the flange (a warning). A job may save the
P variables it uses in its ``//POS`` (``P00100=...``): those are read before VAR.DAT's, and
another job's saved P variables after VAR.DAT's.

Base axes (``BC``), stations (``EC``, ``+MOVJ EC``) and station-coordinated ``SMOV`` motions:
:mod:`robocal.programs.dialects.inform.groups` (the values as :attr:`Target.axes`; an ``SMOV``
target carried by its station).

``VAR.DAT`` (the controller's backup of its global variables) has a position section ``//P`` with
the same header lines (the frame: ``///POSTYPE BASE|ROBOT|USER`` with ``///USER n``, ``///TOOL n``,
``///RCONF``; the units: ``///RECTAN`` mm and deg, ``///PULSE`` encoder pulses) and ``P0001=...``
entries. Given with ``--references`` (or as a program file), its Cartesian P variables that the
jobs' motions reach are corrected; the corrected values are delivered as ``VAR_CAL.DAT`` (a copy
with only those numbers, and a ``///RCONF`` line where a form changes, rewritten; loaded on the
controller as VAR.DAT; :meth:`InformDialect.reference_outputs`). Without it a motion to ``P001`` is
named. A variable a job given assigns at run time (``SET``, ``SUB``, ``ADD``, ``MUL``, ``CNVRT``,
``GETS``, ``MULMAT``, ``SETE``..., anywhere in the job: loops) is named at every motion to it, like a
local variable ``LP``, which no file holds; a write with a run-time index (``SET P[I000] ...``)
names every motion to a variable of that kind.

The VAR.DAT of a controller's CMOS backup (``//VAR``, one ``///P`` line per variable) is read by
:mod:`robocal.programs.dialects.inform.var_file`'s layout, the same way.

A job whose motion instructions give no motion record (all to joint positions, a station's own,
or outside ``//INST``) says so in a warning.
"""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.bom import without_bom
from robocal.core.errors import DataError
from robocal.kinematics.transforms import make_transform
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.inform import marker, simulated, var_file
from robocal.programs.dialects.inform.campaign import inform_job
from robocal.programs.dialects.inform.configuration import YaskawaConfig
from robocal.programs.dialects.inform.groups import BASE_KINDS, STATION_KINDS, Groups, Moved, job_groups
from robocal.programs.dialects.inform.loads import InformLoads
from robocal.programs.dialects.inform.tool_file import is_tool_file, read_tool_file
from robocal.programs.dialects.writing import EXTERNAL_LETTERS
from robocal.programs.model import IDENTITY, Program, Target
from robocal.programs.rotations import matrix_to_zyx
from robocal.programs.source import Number, ProgramText
from robocal.trust.output_marker import corrected_name

_POSITION_MM = 1e-3  # the pendant writes 3 decimals for mm
_ANGLE_DEG = 1e-4  # ... and 4 for degrees
POSE_VALUES = 6
BRANCH_FIELDS = 3  # RCONF's flip, arm and front/back: the least a form must give
CONFIG_FIELDS = 6  # RCONF fields the form of a 6-axis arm uses (the rest, 2 or 18, are kept)
NPOS_KINDS = ("C", "BC", "EC", "P", "BP", "EX")  # the order of ///NPOS

_LINE = re.compile(r"([^\r\n]*)(\r\n|\n|\r|$)")  # CRLF, LF or a lone CR ends a line
_SECTION = re.compile(r"^//(?!/)\s*(\w+)")
_HEADER = re.compile(r"^///\s*(\w+)\s*(.*?)\s*$")
_INDEX = r"(\d{1,9})"  # a position, variable, tool or frame number (a longer one is none)
# C, BC, EC, P, BP, EX, ... (others kept)
_ENTRY = re.compile(r"^\s*([A-Z]{1,4})" + _INDEX + r"\s*=\s*(.*?)\s*$")
_MOTION = re.compile(r"^\s*(MOVJ|MOVL|MOVC|MOVS|IMOV|SMOVJ|SMOVL|SMOVC|SMOV|SYMOVJ|SYMOVL|SYMOVC|EIMOVL|"
                     r"EIMOVC|EIMOVJ|EMOVJ|EMOVL)\b(.*)$")
_NUM = r"([-+]?(?:\d+(?:\.\d*)?|\.\d+))"
_SIX = re.compile(r"(C|P)" + _INDEX + "=" + ",".join([_NUM] * POSE_VALUES) + r"[ \t]*$")  # the usual, fast
_REF = re.compile(r"\b(C|BC|EC|P|BP|EX|LP|LBP|LEX)(?:" + _INDEX + r"|\[([^\]]*)\])")
_SHIFT_ON = re.compile(r"^\s*SFTON\b(.*)$")
_SHIFT_OFF = re.compile(r"^\s*SFTOF\b")
_MFRAME = re.compile(r"^\s*MFRAME\s+UF#\(\s*" + _INDEX + r"\s*\)")
_SETTOOL = re.compile(r"^\s*SETTOOL\s+TL#\(\s*([^)]*?)\s*\)")  # writes tool n's data at run time
ANY_TOOL = "*"  # a SETTOOL whose tool number is not written as a number
# instructions that write a position variable at run time (its first operand)
_WRITES = re.compile(r"^\s*(SET|SETE|GETS|GETE|GETPOS|ADD|SUB|MUL|DIV|CNVRT|CLEAR|SETFILE|GETFILE|MSHIFT|"
                     r"MULMAT|INVMAT|READ|PXEREAD)\s+(LP|P|LBP|BP|LEX|EX)(?:" + _INDEX + r"\b|\[([^\]]*)\])")
ANY_NUMBER = "[]"  # a variable written with a run-time index (SET P[I000] ...): any of its kind may be
_REFP = re.compile(r"^\s*REFP\s+\d+\s+(C|P)" + _INDEX + r"\b")
_LABELED = re.compile(r"^\s*(?:\*\w+\s+)?")
_RUNTIME_INDEX = "the position number is computed at run time"
_BOTH = "used by motions that move differently:"  # a target one correction cannot serve (every use named)
_CONVEYOR = re.compile(r"\bCV#\(")  # a conveyor-synchronised SMOV (conveyor tracking)
_CARTESIAN_POSTYPES = ("BASE", "ROBOT", "USER", "TOOL", "MTOOL")  # ///POSTYPEs of Cartesian numbers
SHOWN_VARIABLES = 8  # P variables a message names before "and n more"


@dataclass
class _Header:
    """The ``///`` state a position takes."""

    postype: str = ""
    rectan: bool = False
    user: str = ""
    tool: str = "0"
    rconf: list[str] | None = None  # the RCONF fields as written
    rconf_line: str = ""  # the RCONF line's text (restored after a position whose form is rewritten)
    values: str = ""  # what the numbers are: RECTAN (mm, deg), PULSE (encoder pulses), ANGLE (deg) ...


@dataclass
class Position:
    """One position entry (``C00003=...``): its kind and number, the header state, the numbers and
    the span of its line (with its line end)."""

    kind: str
    index: int
    numbers: list[Number]
    header: _Header
    line_start: int
    line_end: int
    newline: str
    target: Target | None = None  # the Cartesian target, when it is one
    why: str = ""  # why a motion to it cannot be corrected, when the file says (a backup's VAR.DAT)
    form: tuple[int, int] | None = None  # the span of its form digits (a backup's VAR.DAT), else None


def _lines(text: str):
    """``(start, line without its end, line end)`` of every line; a byte-order mark before the first
    line is not part of it (a file saved by a Windows editor starts its first section there)."""
    pos = len(text) - len(without_bom(text))
    while pos < len(text):
        m = _LINE.match(text, pos)
        yield pos, m.group(1), m.group(2)
        if not m.group(2):
            break
        pos = m.end()


class InformDialect(Dialect):
    name = "Yaskawa INFORM"
    key = "inform"
    campaign_rank = 4
    campaign_external = True  # a positioner's axes move in its campaign programs
    external_axis_names = EXTERNAL_LETTERS  # a station's axes 1.. (its EC values), as Target.axes names them
    positioner_group = True  # a positioner is a station (ST1) of its own: its axes 1..m there
    vendor = "Yaskawa"
    title = "Yaskawa INFORM (.JBI)"
    shared_suffixes = (".dat",)  # the controller's VAR.DAT
    signature = r"^/JOB\b|^//(?:NAME|POS|INST)\b"
    campaign_format, campaign_suffix = "JBI", ".jbi"
    suffixes = (".jbi",)
    scheme = YaskawaConfig()
    frame_help = ("X,Y,Z in mm and Rx,Ry,Rz in deg, as on the pendant's tool and user frame screens; or the "
                  "controller's TOOL.CND / UFRAME.CND with --references")

    def recognises(self, head):
        return looks_like_inform(head)

    def load_reader(self, tools, schedules):
        return InformLoads()

    def campaign_files(self, joints, robot, path, **options):
        return {str(path): inform_job(np.rad2deg(joints), robot, path.stem, dialect=self, **options)}

    def mark(self, text, body, note):
        return marker.mark(text, body, note)

    def marked_by_name(self, src):
        return is_variable_file(src)

    def test_program(self, folder, nominal, q, tool, frame, name, variables=False):
        return simulated.write_test_program(self, folder, nominal, q, tool, frame, name, variables)

    def to_pose(self, values):
        values = np.asarray(values, float)
        R = Rotation.from_euler("ZYX", values[:, [5, 4, 3]], degrees=True).as_matrix()  # Rz Ry Rx
        return make_transform(R, values[:, :3] * 1e-3)

    def from_pose(self, T, old):
        zyx = matrix_to_zyx(T[:, :3, :3], np.asarray(old, float)[:, [5, 4, 3]])
        return np.hstack([T[:, :3, 3] * 1e3, zyx[:, [2, 1, 0]]])

    def resolutions(self):
        return np.array([_POSITION_MM] * 3 + [_ANGLE_DEG] * 3)

    def config_edits(self, target, new):
        pos: Position = target.config_spans
        if pos.form is not None:  # a backup's VAR.DAT: the form's digits in the line itself
            return {(pos.form[0], pos.form[0] + CONFIG_FIELDS): "".join(str(min(int(v), 1)) for v in new)}
        old = pos.header.rconf or []
        fields = [str(min(int(v), 1)) for v in new] + old[CONFIG_FIELDS:]
        text = target.source.text
        newline = pos.newline or ("\r\n" if "\r\n" in text else "\n")
        edits = {(pos.line_start, pos.line_start): f"///RCONF {','.join(fields)}{newline}"}
        following = _LINE.match(text, pos.line_end).group(1)
        if pos.header.rconf_line and _ENTRY.match(following):
            # the positions after it keep their form (a rewritten one right after replaces this line)
            edits[(pos.line_end, pos.line_end)] = pos.header.rconf_line + newline
        return edits

    def reference_outputs(self, program, references, corrected, kept):
        """A VAR.DAT among ``references`` whose P variables motions reach: its corrected copy
        (:func:`corrected_variables_name`, the numbers of the corrected P variables rewritten,
        every other byte as it was)."""
        out = {}
        for ref in (r for r in references if is_variable_file(r)):
            if any(t.source is ref and id(t) not in kept for t in program.targets):
                out[ref.path.with_name(corrected_variables_name(ref.path.name))] = corrected[ref.path]
        return out

    def parse(self, sources, frames, tools, references=()):
        prog = Program([], frames={IDENTITY: np.eye(4)}, tools={})
        variables = []  # VAR.DATs given (as a reference or a program file)
        for ref in references:
            if is_tool_file(ref):  # TOOL.CND: its tool frames (its loads: load_data.inform)
                entries = read_tool_file(ref)
                poses = self.to_pose(np.array([e.frame for e in entries.values()]))
                prog.tools.update(zip(entries, poses, strict=True))
            elif is_variable_file(ref):  # VAR.DAT: the global position variables (read below)
                variables.append(ref)
            else:
                prog.frames.update(user_frames(ref))
        prog.declared_tools, prog.declared_frames = dict(prog.tools), dict(prog.frames)
        prog.frames.update(frames)
        prog.tools.update(tools)
        positions: dict[tuple, Position] = {}  # (path or 'global', kind, index) -> position
        jobs = []
        for src in sources:
            if is_tool_file(src) or _UFRAME_LINE.search(src.text):
                raise DataError(f"{src.path.name} is a controller file of tools or user frames (TOOL.CND, "
                                "UFRAME.CND), not a job: give it with --references")
            if _is_variable_file(src):
                variables.append(src)
        if len(variables) > 1:
            given = ", ".join(v.path.name for v in variables)
            raise DataError(f"the global variables are given twice ({given}): give VAR.DAT once")
        for src in [*variables, *(s for s in sources if not _is_variable_file(s))]:
            found = _read_positions(src, prog)
            scope = "global" if _is_variable_file(src) else src.path
            for p in found:
                positions[(scope, p.kind, p.index)] = p
                if scope != "global" and p.kind == "P":  # a P variable another job saves in its //POS
                    positions.setdefault(("jobs", "P", p.index), p)
            if scope != "global":
                jobs.append(src)
        used: set[int] = set()  # targets a corrected motion reaches
        named: set[int] = set()  # ... a named motion reaches
        writes = {id(src): _run_time_writes(src) for src in jobs}
        shared: dict[str, str] = {}  # global variables (P, BP, EX) a job given assigns: for every job
        for w in writes.values():
            for name, where in w.items():
                if not name.startswith("L"):
                    shared.setdefault(name, where)
        for src in jobs:
            _motions(src, positions, prog, used, named, shared | writes[id(src)])
        # a reached target uses TOOL 0, without data for it: anywhere (tool0) / in TOOL.CND (own_tool0)
        tool0 = own_tool0 = False
        for p in {id(p): p for p in positions.values()}.values():  # a job's P variable is under two keys
            t = p.target
            if t is None:
                continue
            if id(t) in named and id(t) not in used:
                continue
            if id(t) not in used:
                if t.source not in references:  # a backup's VAR.DAT holds every variable of the cell
                    prog.warnings.append(f"{t.where}: no motion of these jobs reaches it: left as it is")
                continue
            tool0 |= t.tool == "0" and "0" not in prog.tools
            own_tool0 |= t.tool == "0" and "0" not in prog.declared_tools
            t.order = len(prog.targets)
            prog.targets.append(t)
        if own_tool0:  # the controller's flange, which a --tool 0 replaces
            prog.declared_tools["0"] = np.eye(4)
        if tool0:
            prog.tools["0"] = np.eye(4)
            prog.warnings.append("TOOL 0 has no data given: taken as the flange (give "
                                 "--tool 0=X,Y,Z,Rx,Ry,Rz if tool file 0 holds a tool)")
        prog.warnings += [_delivered(ref, prog.targets) for ref in variables if ref in references
                          and any(t.source is ref for t in prog.targets)]
        prog.targets.sort(key=lambda t: (str(t.source.path), t.offset))
        for k, t in enumerate(prog.targets):
            t.order = k
        return prog


def corrected_variables_name(name: str) -> str:
    """The name of a VAR.DAT's corrected copy: ``VAR.DAT`` -> ``VAR_CAL.DAT`` (another name than the
    controller's own, so that the backup it was read from is never overwritten)."""
    return corrected_name(name)


def _delivered(ref: ProgramText, targets: list[Target]) -> str:
    """What the filter does with the P variables of VAR.DAT ``ref`` given with --references."""
    names = [t.name for t in targets if t.source is ref]
    shown = ", ".join(names[:SHOWN_VARIABLES]) + (f" and {len(names) - SHOWN_VARIABLES} more"
                                                  if len(names) > SHOWN_VARIABLES else "")
    return (f"{ref.path.name}: the {len(names)} P variable(s) these jobs move to ({shown}) are corrected in "
            f"{corrected_variables_name(ref.path.name)}, a copy of {ref.path.name} with only their numbers "
            f"(and a ///RCONF line where the form changes) rewritten: load it on the controller as "
            f"{ref.path.name}. P variables are global: a job not given here that writes one changes it")


def is_variable_file(src: ProgramText) -> bool:
    """A controller's VAR.DAT: no ``/JOB`` line; a backup's ``//VAR`` with ``///P`` lines, or position
    sections (``//P``) with ``P0000=`` entries."""
    sections = re.search(r"^//(?:P|BP|EX)\s*$", without_bom(src.text), re.MULTILINE) is not None
    return _is_variable_file(src) and not is_tool_file(src) and not _UFRAME_LINE.search(src.text) and (
        sections or var_file.is_cmos_variables(src))


def _is_variable_file(src: ProgramText) -> bool:
    """A controller variable file (VAR.DAT): no ``/JOB`` line, position sections ``//P``."""
    return not re.search(r"^\s*/JOB\b", without_bom(src.text), re.MULTILINE)



def _read_positions(src: ProgramText, prog: Program) -> list[Position]:
    """The position entries of a job's ``//POS`` (or a VAR.DAT's ``//P``, ``//BP``, ``//EX``, or
    the ``///P`` lines of a backup's VAR.DAT: :func:`_backup_positions`) with their header state;
    Cartesian robot positions become targets. ``///NPOS`` is checked."""
    if var_file.is_cmos_variables(src):
        return _unique(src, _backup_positions(src))
    out: list[Position] = []
    section = ""
    head = _Header()
    state: tuple[_Header, np.ndarray | None] | None = None  # a copy of head for the entries, until it changes
    npos: tuple[int, list[int]] | None = None
    for start, line, end in _lines(src.text):
        sec = _SECTION.match(line)
        if sec:
            section = sec.group(1).upper()
            head, state = _Header(), None
            continue
        if section not in ("POS", "P", "BP", "EX"):
            continue
        h = _HEADER.match(line)
        if h:
            _header_line(src, start, line, h, head)
            state = None
            if h.group(1).upper() == "NPOS":
                npos = (start, [int(v) for v in h.group(2).split(",")])
            elif h.group(1).upper() == "POSTYPE":  # a new coordinate system: what its numbers are
                head.rectan, head.values = _postype_values(head.postype)
            continue
        if not line.strip() or line.lstrip().startswith("'"):
            continue
        fast = _SIX.match(line)
        if fast:
            kind, index = fast.group(1), fast.group(2)
            nums = [Number(start + fast.start(k), start + fast.end(k), fast.group(k)) for k in range(3, 9)]
        else:
            e = _ENTRY.match(line)
            if not e:
                raise DataError(f"{src.where(start)}: malformed position line {line.strip()[:60]!r}: "
                                "expected ///HEADER or NAME=values")
            kind, index = e.group(1), e.group(2)
            nums = src.numbers_in(start + e.start(3), start + e.end(3))
            if len(nums) != len(e.group(3).split(",")):
                raise DataError(f"{src.where(start)}: malformed position {kind}{index}: values must be "
                                "numbers separated by commas")
        if state is None:
            flags = head.rconf[:CONFIG_FIELDS] if head.rconf is not None else None
            # an older form without the R, T, S flags: within -180 < angle <= 180
            config = None if flags is None else \
                np.array([int(f) for f in flags] + [0] * (CONFIG_FIELDS - len(flags)))
            state = (_Header(**vars(head)), config)
        header, config = state
        pos = Position(kind, int(index), nums, header, start, start + len(line) + len(end), end)
        out.append(pos)
        if kind in ("C", "P", "LP") and header.rectan and header.postype in ("BASE", "ROBOT", "USER"):
            name = f"{kind}{index}"
            if len(nums) != POSE_VALUES:
                prog.warnings.append(f"{src.where(start)}: {name} has {len(nums)} values (a 7-axis arm's "
                                     "form): left as it is")
                continue
            if header.postype == "USER" and not header.user:
                raise DataError(f"{src.where(start)}: {name} is a USER position but no ///USER n precedes it")
            pos.target = Target(src, start, name, nums, frame=header.user if header.postype == "USER" else
                                IDENTITY, tool=header.tool, config=config, config_spans=pos)
    if npos is not None:
        counts = [sum(p.kind == k for p in out) for k in NPOS_KINDS]
        if npos[1] != counts[:len(npos[1])]:
            prog.warnings.append(f"{src.where(npos[0])}: ///NPOS {','.join(map(str, npos[1]))} but the "
                                 f"section holds {','.join(map(str, counts))} (C, BC, EC, P, BP, EX)")
    return _unique(src, out)


def _unique(src: ProgramText, positions: list[Position]) -> list[Position]:
    """``positions``, each number given once; a number given twice (C00003 on two lines of a job's
    //POS, P001 twice in a VAR.DAT) is a DataError naming both lines: which copy the controller
    loads is not documented, and correcting one would leave the other as it was."""
    seen: dict[tuple[str, int], Position] = {}
    for pos in positions:
        first = seen.setdefault((pos.kind.upper(), pos.index), pos)
        if first is not pos:
            head = src.text[pos.line_start:pos.line_start + 40]
            written = re.match(rf"\s*({pos.kind}0*{pos.index})\b", head)
            name = written[1] if written else f"{pos.kind}{pos.index:03d}"  # as the file writes it
            raise DataError(f"{src.where(pos.line_start)}: {name} is given twice "
                            f"(first at line {src.line_of(first.line_start)}): give each position number "
                            "once (which copy the controller keeps is not known, and correcting one would "
                            "leave the other as it was)")
    return positions


def _backup_positions(src: ProgramText) -> list[Position]:
    """The P variables of a controller backup's VAR.DAT (:mod:`.var_file`): BASE and ROBOT ones
    become targets, a pulse one a joint position; the others say why a motion
    to them is not corrected."""
    out = []
    for e in var_file.entries(src):
        postype = var_file.TYPES.get(e.type, "") if e.kind in ("PULSE", "RECTAN") else ""
        cartesian = e.kind == "RECTAN" and postype in ("BASE", "ROBOT")
        form = src.text[e.form[0]:e.form[1]]
        values = "RECTAN" if cartesian else "PULSE" if postype == "PULSE" else ""
        header = _Header(postype=postype, rectan=cartesian, tool=e.tool, rconf=list(form) or None,
                         values=values)
        nums = src.numbers_in(*e.values)[:POSE_VALUES] if cartesian else []
        name = f"P{e.index:03d}"
        why = ""
        if e.kind == "UNUSED":
            why = f"{name} is \"UNUSED\" in {src.path.name}: it holds no value (one is assigned at run time)"
        elif not postype:
            why = (f"{name} is in coordinate type {e.type} of {src.path.name} (user or tool coordinates: "
                   "which field holds the frame number is not read)" if e.type is not None else
                   f"{name}'s line in {src.path.name} is not \"RECTAN\" or \"PULSE\" followed by "
                   "a,b,tool,FORM,c,TYPE,values")
        pos = Position("P", e.index, nums, header, e.start, e.end, "", why=why,
                       form=e.form if cartesian else None)
        if cartesian and len(nums) == POSE_VALUES:
            config = np.array([int(f) for f in form[:CONFIG_FIELDS]])
            pos.target = Target(src, e.start, name, nums, frame=IDENTITY, tool=e.tool, config=config,
                                config_spans=pos)
        out.append(pos)
    return out


def _postype_values(postype: str) -> tuple[bool, str]:
    """``(rectan, values)`` a ``///POSTYPE`` implies until a ``///RECTAN``, ``///PULSE`` or ``///ANGLE``
    line says otherwise: BASE, ROBOT, USER and TOOL positions are Cartesian (mm, deg) whatever the
    line order (an offline generator may write ``///RECTAN`` before ``///POSTYPE`` or leave it out
    after a second ``///POSTYPE BASE``: the controller reads Cartesian numbers there), PULSE
    positions encoder pulses; another one is unknown until its line."""
    if postype in _CARTESIAN_POSTYPES:
        return True, "RECTAN"
    return False, "PULSE" if postype == "PULSE" else ""


def _header_line(src: ProgramText, start: int, line: str, h: re.Match, head: _Header) -> None:
    """Apply a ``///KEY value`` line of a position section to ``head`` (malformed: DataError)."""
    key, value = h.group(1).upper(), h.group(2)
    if key == "NPOS":
        if not re.fullmatch(r"\d{1,9}(?:\s*,\s*\d{1,9})*", value):
            raise DataError(f"{src.where(start)}: malformed ///NPOS {value!r}: expected 6 integers")
    elif key == "POSTYPE":
        head.postype = value.upper()
    elif key in ("RECTAN", "PULSE", "ANGLE"):
        head.rectan = key == "RECTAN"
        head.values = key
    elif key in ("USER", "TOOL"):
        if not re.fullmatch(_INDEX, value):
            raise DataError(f"{src.where(start)}: malformed ///{key} {value!r}: expected a number")
        setattr(head, key.lower(), str(int(value)))
    elif key == "RCONF":
        fields = [f.strip() for f in value.split(",")] if value else []
        if len(fields) < BRANCH_FIELDS or any(f not in ("0", "1") for f in fields[:CONFIG_FIELDS]) \
                or not all(f.isdigit() for f in fields):
            raise DataError(f"{src.where(start)}: malformed ///RCONF {value!r}: expected flags 0 or 1 "
                            "(flip, arm, front/back, R, T, S, ...)")
        head.rconf, head.rconf_line = fields, line


def _run_time_writes(src: ProgramText) -> dict[str, str]:
    """The position variables job ``src`` assigns at run time (anywhere: loops): ``'P1'``, ``'LP0'``
    (a run-time index: ``'P[]'``, any of the kind) -> the instruction and where."""
    out: dict[str, str] = {}
    for start, line, _ in _instructions(src):
        w = _WRITES.match(_LABELED.sub("", line, count=1))
        if w:
            name = w.group(2) + (str(int(w.group(3))) if w.group(3) is not None else ANY_NUMBER)
            what = w.group(1) if w.group(3) is not None else f"{w.group(1)} {w.group(2)}[{w.group(4)}]"
            out.setdefault(name, f"{what} ({src.where(start)})")
    return out


def _motions(src: ProgramText, positions: dict, prog: Program, used: set, named: set,
             runtime: dict[str, str]) -> None:
    """Account for every motion of the job's ``//INST`` in text order: a Cartesian C or P position
    is a corrected target; joint (PULSE) positions need nothing; incremental, shifted, conveyor-
    or station-synchronised motions, base axes, stations, positions assigned at run time
    (``runtime``: :func:`_run_time_writes` of this job and the global variables any job given
    assigns) and positions whose tool the job rewrites (``SETTOOL TL#(n) P..``: the tool file's
    data of tool n from a position variable) are named."""
    shift = ""  # the SFTON in effect
    mframe: dict[str, str] = {}  # user frame -> the MFRAME that sets it
    settool: dict[str, str] = {}  # tool -> the SETTOOL that writes it (anywhere: loops)
    groups = job_groups(src.text)
    uses: dict[int, tuple[str | None, dict]] = {}  # id(target) -> (carrying unit, values) of its first use
    inst = [(start, _LABELED.sub("", line, count=1) if "*" in line else line)
            for start, line, _ in _instructions(src)]
    for start, body in inst:
        st = _SETTOOL.match(body)
        if st:
            number = re.fullmatch(_INDEX, st.group(1))
            settool.setdefault(str(int(number.group(1))) if number else ANY_TOOL, src.where(start))
    seen = Counter()  # the job's motion instructions by what the reader makes of them
    for start, body in inst:
        if _MOTION.match(body):
            seen["instructions"] += 1
        if _SHIFT_OFF.match(body):
            shift = ""
            continue
        on = _SHIFT_ON.match(body)
        if on:
            shift = f"SFTON{on.group(1).split(chr(39))[0].rstrip()} ({src.where(start)})"
            continue
        mf = _MFRAME.match(body)
        if mf:
            mframe[str(int(mf.group(1)))] = src.where(start)
            continue
        ref_point = _REFP.match(body)
        if ref_point:  # a weaving reference point: a taught position like the motions' (not a motion)
            kind, index = ref_point.group(1), int(ref_point.group(2))
            pos = positions.get((src.path, kind, index)) or positions.get(("global", kind, index)) \
                or positions.get(("jobs", kind, index))
            if pos is not None and pos.target is not None:
                used.add(id(pos.target))
            continue
        mv = _MOTION.match(body)
        if not mv:
            continue
        instr, rest = mv.group(1), mv.group(2).split("'")[0].split("//")[0]  # ' and // comments
        parts = rest.split("+")  # the robot's group, then each other group's motion
        seen["accounted"] += _other_robots(src, start, parts, groups, prog, positions, named)
        refs = list(_REF.finditer(parts[0]))
        robot_refs = [r for r in refs if r.group(1) in ("C", "P", "LP")]
        ref = robot_refs[0] if robot_refs else None
        pos = None
        if ref is not None and ref.group(2) is not None:
            kind, index = ref.group(1), int(ref.group(2))
            pos = positions.get((src.path, kind, index))  # the job's own //POS (P too), else VAR.DAT
            if pos is None and kind == "P":  # a global variable: VAR.DAT, else another job that saves it
                pos = positions.get(("global", "P", index)) or positions.get(("jobs", "P", index))
        if pos is not None and pos.target is None and instr != "IMOV" and not pos.why and (
                pos.header.postype == "PULSE" or not pos.header.rectan):
            prog.motions.append((src.path, start, np.full(6, np.nan)))  # a joint position: no correction
            seen["joint"] += 1
            continue
        if ref is None and refs and all(r.group(1) in STATION_KINDS for r in refs):
            seen["station"] += 1
            continue  # a station's motion alone (a job of ///GROUP1 ST1, MOVJ EC00000): the arm stays
        seen["accounted"] += 1
        acc = prog.motion(src, start, instr)
        if ref is None:
            prog.skip(src.where(start), instr, "no robot position (C, P or LP) in the instruction", acc)
            continue
        label = ref.group(0)
        why = _named_reason(instr, ref, rest, shift, runtime)
        if why:
            if pos is not None and pos.target is not None:
                named.add(id(pos.target))
            prog.skip(src.where(start), instr, why, acc, label)
            continue
        if pos is None:
            global_help = " (a global position variable: give the controller's VAR.DAT with --references)"
            prog.skip(src.where(start), instr, f"{label} is not in the files given" + (
                global_help if kind == "P" else ""), acc, label)
            continue
        if pos.target is None:
            postype = pos.header.postype or '?'
            system = f"{label} is in an unsupported coordinate system (///POSTYPE {postype})"
            why = pos.why or (system if len(pos.numbers) == POSE_VALUES else
                              f"{label} is not a 6-value Cartesian position")
            prog.skip(src.where(start), instr, why, acc, label)
            continue
        t = pos.target
        if groups.on_track and pos.header.postype == "BASE":
            named.add(id(t))
            prog.skip(src.where(start), instr, f"{label} is a BASE position of a robot on base axes "
                                               "(///GROUP ... BS): where it is for the robot depends on "
                                               "the axes' position", acc, label)
            continue
        written = settool.get(t.tool, settool.get(ANY_TOOL))
        if written:
            named.add(id(t))
            prog.skip(src.where(start), instr, f"{label} is taught with tool {t.tool}, whose data the job "
                                               f"writes at run time by SETTOOL at {written}", acc, label)
            continue
        if t.frame in mframe:
            named.add(id(t))
            prog.skip(src.where(start), instr, f"{label} is in user frame {t.frame}, set at run time by "
                                               f"MFRAME at {mframe[t.frame]}", acc, label)
            continue
        if groups.on_track and pos.header.postype == "USER":
            named.add(id(t))
            prog.skip(src.where(start), instr, f"{label} is a USER position of a robot on base axes "
                                               "(///GROUP ... BS): its user frame is in base coordinates, so "
                                               "where it is for the robot depends on the axes' position",
                      acc, label)
            continue
        if id(t) not in prog.not_corrected:
            why = _external(prog, t, instr, _moved(src, parts, refs, groups, positions), groups, uses)
            if why.startswith(_BOTH):  # every motion reaching it is named
                prog.not_corrected[id(t)] = why
                prog.warnings.append(f"{t.where}: not corrected: {why}")
                prog.uncorrected.append(f"{t.where}: not corrected: {why}")
                why = ""
            if why:
                named.add(id(t))
                prog.skip(src.where(start), instr, why, acc, label)
                continue
        if id(t) in prog.not_corrected:
            named.add(id(t))
            used.discard(id(t))
            acc.reach(t, label)
            continue
        used.add(id(t))
        acc.reach(t, label)
        prog.motions.append((src.path, start, t))
    prog.warnings += _unaccounted(src, seen)


def _other_robots(src: ProgramText, start: int, parts: list[str], groups: Groups, prog: Program,
                  positions: dict, named: set) -> int:
    """Name the motions of another robot in one instruction (``MOVL C00000 +MOVL C00001`` in a job of
    ``///GROUP1 RB1`` and ``///GROUP2 RB2``): its positions are that robot's, which this filter's
    model is not (``named``: their targets' ids); how many were named."""
    end = src.text.find("\n", start)  # not a slice of the rest of the text: linear in a 100k-motion job
    line = src.text[start:end if end >= 0 else len(src.text)]
    pluses = [k for k, c in enumerate(line) if c == "+"]
    count = 0
    for k, part in enumerate(parts[1:], start=1):
        group = groups.others[k - 1] if k - 1 < len(groups.others) else ()
        robots = [u for u in group if u.startswith("RB")]
        ref = next((r for r in _REF.finditer(part) if r.group(1) in ("C", "P", "LP")), None)
        if not robots or ref is None or k > len(pluses):
            continue
        instr = "+" + (part.split() or [""])[0]
        if ref.group(2) is not None:
            pos = positions.get((src.path, ref.group(1), int(ref.group(2))))
            if pos is not None and pos.target is not None:
                named.add(id(pos.target))
        why = (f"{ref.group(0)} is a position of {robots[0]}, another robot than the job's first "
               f"({', '.join(groups.robot)}): filter it with {robots[0]}'s model")
        prog.skip(src.where(start), instr, why, prog.motion(src, start + pluses[k - 1], instr), ref.group(0))
        count += 1
    return count


def _unaccounted(src: ProgramText, seen: Counter) -> list[str]:
    """A warning when the job's text holds motion instructions and none has a record (0 motions
    corrected or named): what the reader made of them (joint positions, a station's own motions)
    or where they are that it does not read (outside ``//INST``), never silence."""
    if seen["accounted"]:
        return []
    outside = sum(1 for _, line, _ in _lines(src.text) if _MOTION.match(_LABELED.sub("", line, count=1))) \
        - seen["instructions"]
    parts = [f"{n} to joint (pulse) positions, which need no correction" for n in [seen["joint"]] if n]
    parts += [f"{n} of a station alone (the arm stays)" for n in [seen["station"]] if n]
    parts += [f"{n} outside its //INST section, not read as instructions" for n in [outside] if n]
    if not parts:
        return []
    total = seen["instructions"] + outside
    return [f"{src.path.name}: {total} motion instruction(s) and no motion of the arm to a Cartesian "
            f"position: {'; '.join(parts)}"]


def _moved(src: ProgramText, parts: list[str], refs: list, groups: Groups, positions: dict) -> Moved:
    """The base-axis and station positions a motion instruction moves with (``parts``: the
    instruction split at its ``+``), each with its unit and its values when the files hold them."""
    out = Moved()
    for k, part in enumerate(parts):
        for r in refs if k == 0 else _REF.finditer(part):
            kind = r.group(1)
            if kind not in STATION_KINDS + BASE_KINDS:
                continue
            unit = (groups.station_of(k) or "a station") if kind in STATION_KINDS else \
                next((u for u in groups.robot if u.startswith("BS")), "base axes")
            label = ("+" if k else "") + r.group(0)
            pos = None
            if r.group(2) is not None:
                index = int(r.group(2))
                pos = positions.get((src.path, kind, index)) or positions.get(("global", kind, index))
            nums = [n.value for n in pos.numbers] if pos is not None else None
            out.values.append((unit, label, kind, nums, pos.header.values if pos is not None else ""))
    return out


def _external(prog: Program, t: Target, instr: str, moved: Moved, groups: Groups, uses: dict) -> str:
    """Record on target ``t`` what its motion moves with (:attr:`Target.external`,
    :attr:`Target.axes`; a station-coordinated motion: ``t``'s frame becomes one the station carries,
    :attr:`Program.carried`), or why the motion cannot be corrected ('')."""
    unit, values = None, {}
    if instr.startswith("SMOV"):  # station-coordinated: the target moves with the station's plate
        stations = moved.station()
        if not stations:
            unit = groups.stations[0] if len(groups.stations) == 1 else ""
            return (f"coordinated with {unit or 'a station'} (SMOV), but the instruction gives no station "
                    "position (EC): where the station is depends on the motion before")
        unit, label, nums, how = stations[0]
        if unit == "a station":
            return f"coordinated with the station of {label}, but the ///GROUP lines name no one station"
        if nums is None:
            where = _RUNTIME_INDEX if "[" in label else "not in the files given"
            return f"coordinated with {unit} (SMOV), but its position {label}: {where}"
        if how != "ANGLE":
            return (f"coordinated with {unit} (SMOV), but its position {label} is in encoder pulses (///"
                    f"{how or 'PULSE'}): pulses per degree are controller parameters, not the cell file's")
        values = {f"E{k + 1}": v for k, v in enumerate(nums)}  # the station's axes 1.. in degrees
    else:
        for u, label, kind, nums, how in moved.values:  # each unit's axes (NaN: not in the files given)
            if nums is None:
                values[f"{u} {label.lstrip('+')}"] = float("nan")
                continue
            pulses = "" if how == "ANGLE" or kind in BASE_KINDS and how == "RECTAN" else " (pulses)"
            values.update({f"{u} axis {k + 1}{pulses}": v for k, v in enumerate(nums)})
    first = uses.get(id(t))
    if first is not None:
        if first[0] != unit or unit is not None and first[1] != values:
            was, now = (f"coordinated with {u} at {', '.join(f'{k} = {x:g}' for k, x in v.items())}" if u
                        else "not coordinated" for u, v in (first, (unit, values)))
            return (f"{_BOTH} {now} here, {was} before: one corrected target cannot serve both; teach a copy "
                    "for each use")
        return ""
    uses[id(t)] = (unit, values)
    if not moved.values:
        return ""
    t.external, t.axes = moved.text(), values
    if unit is not None:
        key = f"{t.frame}@{unit}"
        if t.frame in prog.frames:
            prog.frames.setdefault(key, prog.frames[t.frame])
        prog.carried[key] = unit
        prog.in_world.add(key)  # the robot's position as taught with the station at its values
        t.frame = key
    return ""


def _instructions(src: ProgramText):
    """The lines of the job's ``//INST`` section that are instructions (not headers or comments)."""
    section = ""
    for start, line, end in _lines(src.text):
        sec = _SECTION.match(line)
        if sec:
            section = sec.group(1).upper()
        elif section == "INST" and not line.startswith("///") and not line.lstrip().startswith("'"):
            yield start, line, end


def _named_reason(instr: str, ref, rest: str, shift: str, runtime: dict) -> str:
    """Why a motion cannot be corrected ('' when it can, perhaps with a station or base axes:
    :func:`_external`)."""
    label = ref.group(0)
    if ref.group(2) is None:
        return f"{label}: {_RUNTIME_INDEX}"
    if instr == "IMOV":
        return f"{label} is an increment (IMOV): a displacement, not a pose"
    if instr.startswith("SMOV") and _CONVEYOR.search(rest):
        return f"{label} follows a conveyor (SMOV ... CV#): the pose moves at run time"
    if instr.startswith("SYMOV"):
        return f"{label} is synchronised with a station (SYMOV): the pose moves with the station"
    if instr.startswith(("EIMOV", "EMOV")):
        return f"{label}: a motion of an external axis group"
    name = f"{ref.group(1)}{int(ref.group(2))}"
    if name in runtime:
        return f"{label} is assigned at run time by {runtime[name]}"
    if ref.group(1) + ANY_NUMBER in runtime:
        return (f"{label} may be assigned at run time by {runtime[ref.group(1) + ANY_NUMBER]}: that variable "
                "number is computed at run time")
    if ref.group(1) == "LP":
        return (f"{label} is a local position variable: assigned at run time (a job's local variables are "
                "in no file)")
    if shift:
        return f"{label} is shifted at run time by {shift}"
    return ""


_UFRAME = re.compile(r"^//UFRAME\s+" + _INDEX + r"\s*$")
_UFRAME_LINE = re.compile(r"^//UFRAME\s+\d+\s*$", re.MULTILINE)
_BUSER = re.compile(r"^////BUSER\s+(.*?)\s*$")


def user_frames(src: ProgramText) -> dict[str, np.ndarray]:
    """The user frames of a controller's UFRAME.CND (``//UFRAME n`` blocks, each with its frame in
    the base coordinates ``////BUSER X,Y,Z,Rx,Ry,Rz``, mm and deg): 'n' -> 4x4 (m)."""
    out: dict[str, np.ndarray] = {}
    current = None
    for start, line, _ in _lines(src.text):
        head = _UFRAME.match(line)
        if head:
            current = str(int(head.group(1)))
            continue
        b = _BUSER.match(line)
        if b and current is not None:
            nums = src.numbers_in(start + b.start(1), start + b.end(1))
            if len(nums) != POSE_VALUES or len(b.group(1).split(",")) != POSE_VALUES:
                raise DataError(f"{src.where(start)}: malformed ////BUSER of user frame {current}: expected "
                                "X,Y,Z,Rx,Ry,Rz")
            out[current] = InformDialect().to_pose(np.array([[n.value for n in nums]]))[0]
            current = None
    if not out:
        raise DataError(f"{src.path.name}: no //UFRAME n with ////BUSER X,Y,Z,Rx,Ry,Rz: not a UFRAME.CND "
                        "nor a TOOL.CND (//TOOL n) nor a VAR.DAT (//P with P0000= entries)")
    return out


def looks_like_inform(text: str) -> bool:
    """A job (``/JOB`` first) or a VAR.DAT (``//`` sections with ``P0000=`` entries, or a backup's
    ``//VAR`` and ``///PFNUM``)."""
    head = re.sub(r"\r\n?", "\n", without_bom(text)).lstrip(" \t\n")[:4000]  # a lone CR ends a line too
    if re.search(r"^/JOB\b", head, re.MULTILINE) and re.search(r"^//(?:NAME|POS|INST)\b", head, re.MULTILINE):
        return True  # a job (an offline generator may put a ' comment line before /JOB)
    if re.match(r"//VAR[ \t]*[\r\n]+///PFNUM\b", head):
        return True  # a controller backup's VAR.DAT
    return bool(re.match(r"//\w", head) and re.search(r"^P\d+=", head, re.M))
