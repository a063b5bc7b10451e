"""ABB RAPID modules (.mod, .modx, .prg, .sys).

* ``robtarget`` = ``[[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax_a,...,eax_f]]``: mm, unit
  quaternion w-first, configuration (see
  :class:`robocal.programs.dialects.rapid.configuration.ABBConfig`), external axes (left alone).
  Declared ``CONST``/``PERS``/``VAR`` (also ``LOCAL``/``TASK``, arrays
  ``name{n}`` / ``name{n,m}``) or written inline in a motion instruction.
* ``tooldata`` = ``[robhold,[[x,y,z],[q1..q4]],[load...]]``: TCP = flange * tframe.
* ``wobjdata`` = ``[robhold,ufprog,ufmec,[[uframe]],[[oframe]]]``: target pose in the world
  (= robot base) frame = uframe * oframe * robtarget. A work object a mechanical unit moves
  (robhold FALSE, ufprog FALSE, ufmec ``"STN1"``) is a frame on that unit's plate
  (:attr:`Program.carried`): the controller defines its user frame by the unit, so the targets are
  in oframe on the plate and a stored uframe is not used (said when it is not the identity);
  robhold TRUE (the robot holds the work: MultiMove, a stationary tool) is not filtered. The
  robtarget's external axes that are not 9E9 are its :attr:`Target.axes` (``eax_b`` -> value).
* Motion instructions and the positions of their arguments (optional ``\\Arg`` removed):
  MoveL/MoveJ and their DO/AO/GO/Sync forms: ToPoint, Speed, Zone, Tool; MoveC: CirPoint,
  ToPoint, Speed, Zone, Tool; TriggL/TriggJ: ToPoint, Speed, Trigg, Zone, Tool; TriggC: CirPoint,
  ToPoint, Speed, Trigg, Zone, Tool; SearchL: Signal, SearchPoint (an output: left alone),
  ToPoint, Speed, Tool; SearchC: Signal, SearchPoint, CirPoint, ToPoint, Speed, Tool. The work
  object is ``\\WObj:=name`` (default wobj0). ``Offs(p, ...)`` and ``RelTool(p, ...)`` (any case)
  whose amounts are constant expressions (numbers, CONST nums and their array elements, + - * /,
  parentheses; :mod:`robocal.programs.expressions`) count as uses of ``p``; other amounts are
  named per motion. ``MoveAbsJ`` (jointtarget) and every other instruction are left alone.

Comments (``!`` to the end of the line) and strings are masked before anything is searched.
"""

from __future__ import annotations

import functools
import re

import numpy as np

from robocal.core.errors import DataError
from robocal.kinematics.transforms import make_transform
from robocal.programs.aggregate import (
    Word,
    close_bracket,
    numbers_of,
    parse_aggregate,
    shape_pattern,
    split_top,
)
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.rapid import marker, simulated
from robocal.programs.dialects.rapid.campaign import RAPID_EXTAX, rapid_module
from robocal.programs.dialects.rapid.configuration import ABBConfig
from robocal.programs.dialects.rapid.loads import RapidLoads
from robocal.programs.dialects.rapid.syntax import COMMENT_RE, STRING_RE
from robocal.programs.expressions import constant_value
from robocal.programs.flow import Flow, Routine, order_by_execution
from robocal.programs.model import Program, Target
from robocal.programs.motions import Undeclared
from robocal.programs.rotations import matrix_to_quat, quat_to_matrix
from robocal.programs.runtime import Meant, RunTime, RuntimeSite, merged
from robocal.programs.source import Number, ProgramText

_DECL = re.compile(r"\b(?:(?:LOCAL|TASK)\s+)?(CONST|PERS|VAR)\s+(robtarget|tooldata|wobjdata)\s+"
                   r"([A-Za-z]\w*)\s*(\{[^}]*\})?\s*(:=)?", re.IGNORECASE)
# instruction -> (positions of the robtarget arguments, position of the tool argument), counting
# the positional arguments only (optional \Arg and switches removed)
_MOVES = {"movel": ((0,), 3), "movej": ((0,), 3), "movec": ((0, 1), 4),
          "triggl": ((0,), 4), "triggj": ((0,), 4), "triggc": ((0, 1), 5),
          "triggjios": ((0,), 3), "trigglios": ((0,), 3),
          "searchl": ((2,), 4), "searchc": ((2, 3), 5),
          # arc welding (RobotWare Arc): ArcL ToPoint, Speed, Seam, Weld, Zone, Tool
          "arcl": ((0,), 5), "arclstart": ((0,), 5), "arclend": ((0,), 5),
          "arcc": ((0, 1), 6), "arccstart": ((0, 1), 6), "arccend": ((0, 1), 6),
          # spot welding, dispensing, painting, continuous application platform
          "spotl": ((0,), 3), "spotj": ((0,), 3), "spotml": ((0,), 3),
          "displ": ((0,), 4), "dispc": ((0, 1), 5), "paintl": ((0,), 3), "paintc": ((0, 1), 4),
          "capl": ((0,), 6), "capc": ((0, 1), 7),
          # SeamFind (laser / touch sensing): Joint \FoundPoint, ToPoint, Speed, JointData, Schedule, Tool
          "seamfind": ((1,), 5)}
for _base, _spec in (("movel", ((0,), 3)), ("movej", ((0,), 3)), ("movec", ((0, 1), 4))):
    for _suffix in ("do", "ao", "go", "sync"):
        _MOVES[_base + _suffix] = _spec
_MOVE = re.compile(r"\b(" + "|".join(_MOVES) + r")\b", re.IGNORECASE)
_STATEMENT = re.compile(r"[^;]+")
_WORD = re.compile(r"\s*([A-Za-z]\w*)")
_REF = re.compile(r"([A-Za-z]\w*)\s*(\{[^}]*\})?\s*((?:\.\s*[A-Za-z]\w*)*)")
_NAMED_ARG = re.compile(r"\s*[A-Za-z]\w*\s*:=")
_CALLED = re.compile(r"\s*(Offs|RelTool)\s*\(", re.IGNORECASE)
_FUNCTION = re.compile(r"\s*([A-Za-z]\w*)\s*\(")
# functions whose robtarget is computed from the joints the robot is at or is given (already in the
# controller's corrected space: not routed through a run-time correction)
_REACHED = ("crobt", "calcrobt")
_FUNC_BODY = re.compile(r"\bfunc\s+robtarget\s+([a-z]\w*)([\s\S]*?)\bendfunc\b")  # lower-cased text
_ROUTINE = re.compile(r"\b(proc|func\s+\w+|trap)\s+([a-z]\w*)\s*(?:\(([^)]*)\))?")  # lower-cased text
_ROUTINE_END = re.compile(r"\bend(?:proc|func|trap)\b")
# each \s* before a token of its own (two adjacent ones over a long blank run, as a masked comment
# block leaves, backtrack in quadratic time or worse)
_ASSIGN = re.compile(r"([A-Za-z]\w*)(?:\s*(\{[^}]*\}))?((?:\s*\.\s*[A-Za-z]\w*)*)\s*:=", re.IGNORECASE)
# fields of a tooldata / wobjdata whose change does not move a target (a tool's load)
_POSE_FREE = (".tload",)
# searched in the lower-cased text
_CONSTANT = re.compile(r"\bconst\s+num\s+([a-z]\w*)\s*(\{[^}]*\})?\s*:=\s*([^;]+);")
_SUBSCRIPT = re.compile(r"([A-Za-z]\w*)\s*\{\s*(\d+(?:\s*,\s*\d+)*)\s*\}")  # name{1, 2}: a constant element
_RECORD = re.compile(r"\brecord\s+([a-z]\w*)([\s\S]*?)\bendrecord\b")
_COMPONENT = re.compile(r"([A-Za-z]\w*)\s+([A-Za-z]\w*)\s*;")
_CONF = re.compile(r"\bconf([lj])\s*\\\s*(on|off)\b")
_ACTUNIT = re.compile(r"\bactunit\s+([a-z]\w*)")  # searched in the lower-cased text
# block keywords a statement may begin with before its instruction (a keyword's blank is a lookahead:
# \s+ before [\s\S]*? split a long blank run, a masked comment, in quadratic time)
_LEAD = re.compile(r"\s*(?:(?:LOCAL\s+)?(?:PROC|TRAP)\s+\w+\s*(?:\([^)]*\))?|(?:LOCAL\s+)?FUNC\s+\w+\s+\w+\s*"
                   r"\([^)]*\)|ENDPROC|ENDFUNC|ENDTRAP|ENDIF|ELSE|ENDFOR|ENDWHILE|ENDTEST|DEFAULT\s*:|"
                   r"CASE(?=\s)[^:]+:|(?:ELSE)?IF(?=\s)[\s\S]*?\bTHEN|FOR(?=\s)[\s\S]*?\bDO|WHILE(?=\s)[\s\S]*?\bDO|"
                   r"TEST\s+[^\n]+|MODULE\s+\w+(?:\s*\([^)]*\))?|ERROR(?:\s*\([^)]*\))?|UNDO|BACKWARD|"
                   r"[A-Za-z]\w*:(?!=))", re.IGNORECASE)
_CONF_LIMIT = 2**31  # confdata are quadrants and turns: an integer beyond this is not one
_UNUSED_AXIS = 8e9  # external-axis values at or above this are 9E9: the axis is not used
_POSITION_MM = 1e-3  # mm: 1 um
_QUATERNION = 1e-6  # about 2e-6 rad: 0.4 um at 200 mm from the flange
BUILTIN_TOOLS = ("tool0",)
BUILTIN_WOBJS = ("wobj0",)
# the controller's own data of tool0 and wobj0 (RAPID reference): a declaration equal to them is them
_BUILTIN_DATA = {("tooldata", "tool0"): "[TRUE,[[0,0,0],[1,0,0,0]],[0.001,[0,0,0.001],[1,0,0,0],0,0,0]]",
                 ("wobjdata", "wobj0"): '[FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]]'}
# a robtarget of numbers only (position, quaternion, confdata, six external axes): one match
_ROBTARGET = shape_pattern((3, 4, 4, 6))
_COMPONENTS = ("position", "orientation", "configuration (confdata)", "external axes")  # a robtarget's parts
_DEPTH = 12  # routine calls and assignments followed at most this deep
_EMPTY_DATA = ("holds the quaternion [0,0,0,0]: a placeholder the program assigns at run time, not data to "
               "filter with")
ABSENT = (-1, -1)  # the span bound to an optional parameter that a call leaves out


def _first_offset(node, default: int) -> int:
    """Offset of the first item of a parsed aggregate (``default`` when it holds none)."""
    while isinstance(node, list) and node:
        node = node[0]
    return getattr(node, "start", default)


def _pose_numbers(node, src, at, what) -> list[Number]:
    xyz, quat = numbers_of(node, (3, 4), src, at, what)
    return xyz + quat


class RapidDialect(Dialect):
    name = "ABB RAPID"
    key = "rapid"
    campaign_rank = 0
    campaign_external = True  # a positioner's axes move in its campaign programs
    external_axis_names = RAPID_EXTAX  # a robtarget's extax: logical axis k is eax_<k-th letter>
    arm_axes = external_axis_names  # any of them may be a track or gantry carrying the arm
    campaign_refuses_tracks = True
    runtime_correction = "robocal.programs.dialects.rapid.runtime:RapidRuntime"
    vendor = "ABB"
    signature = r"^\s*(?:MODULE\s+\w+|PROC\s+\w+\s*\(|Move[LJC]\s)"
    campaign_format, campaign_suffix = "RAPID", ".mod"
    suffixes = (".mod", ".modx", ".prg", ".sys")
    scheme = ABBConfig()
    n_values = 7
    shared_decimals = ((3, 4, 5, 6),)  # a quaternion is written at the file's precision
    frame_help = "x,y,z in mm and the quaternion q1,q2,q3,q4 (w first), as in tooldata/wobjdata"

    def load_reader(self, tools, schedules):
        return RapidLoads(tools)

    def campaign_files(self, joints, robot, path, **options):
        return {str(path): rapid_module(np.rad2deg(joints), path.stem, **options)}

    def mark(self, text, body, note):
        return marker.mark(text, body, note)

    def test_program(self, folder, nominal, q, tool, frame, name, variables=False):
        return simulated.write_test_program(self, folder, nominal, q, tool, frame, name, variables)

    def name_key(self, name):
        return name.lower()

    def to_pose(self, values):
        values = np.asarray(values, float)
        q = values[:, 3:7]
        norm = np.linalg.norm(q, axis=1)
        if (np.abs(norm - 1.0) > 1e-3).any():
            raise DataError("a quaternion is not normalised (|q| differs from 1 by more than 1e-3)")
        return make_transform(quat_to_matrix(q), values[:, :3] * 1e-3)

    def from_pose(self, T, old):
        # at the old quaternion's norm: a file's rounding (|q| = 1 +- 1e-6) is not a change
        norm = np.linalg.norm(old[:, 3:7], axis=1, keepdims=True)
        return np.hstack([T[:, :3, 3] * 1e3, matrix_to_quat(T[:, :3, :3], old[:, 3:7]) * norm])

    def resolutions(self):
        return np.array([_POSITION_MM] * 3 + [_QUATERNION] * 4)

    def config_edits(self, target, new):
        cf1, cf4, cf6, cfx = target.config_spans
        row = {"cfx": new[0], "cf1": new[1], "cf4": new[2], "cf6": new[3]}
        return {(n.start, n.end): str(int(row[k])) for n, k in
                ((cf1, "cf1"), (cf4, "cf4"), (cf6, "cf6"), (cfx, "cfx")) if int(float(n.text)) != row[k]}

    # ------------------------------------------------------------------ parsing
    def parse(self, sources, frames, tools, references=()):
        prog = Program([])
        st = _State()
        st.read_only = {r.path for r in references} - {s.path for s in sources}
        flow = Flow()
        lowered, spans = {}, {}
        for src in [*references, *sources]:  # every module's routines first: calls cross modules
            masked = st.masked[src.path] = src.masked([COMMENT_RE], [STRING_RE])
            low = lowered[src.path] = masked.lower()  # case-insensitive searches, without the slow flag
            routines = spans[src.path] = []  # (start, end, name)
            st.functions.update({m.group(1): m.group(2) for m in _FUNC_BODY.finditer(low)})
            for m in _ROUTINE.finditer(low):
                stop = _ROUTINE_END.search(low, m.end())
                routines.append((m.start(), stop.end() if stop else len(low), m.group(2)))
                flow.routines[m.group(2)] = Routine(m.group(2), src, m.start(), routines[-1][1])
                if m.group(1) == "proc":
                    st.procs[m.group(2)] = _params(m.group(3) or "")
        for src in [*references, *sources]:
            masked, low, routines = st.masked[src.path], lowered[src.path], spans[src.path]
            if "const" in low:
                for m in _CONSTANT.finditer(low):
                    if m.group(2):  # CONST num name{n,m} := [[...]]: each element name__i_j
                        try:
                            tree, _ = parse_aggregate(src, low, m.start(3), m.end(3), f"num {m.group(1)}")
                            elements = _elements(tree, m.group(2), src, m.start(), f"num {m.group(1)}")
                        except DataError:
                            continue  # an expression inside: not a table of numbers
                        for suffix, node in elements:
                            if isinstance(node, Number):
                                st.constants[_constant_key(m.group(1) + suffix)] = node.value
                        continue
                    v = _constant(m.group(3), st.constants)
                    if v is not None:
                        st.constants[m.group(1)] = v
            if "record" in low:
                for m in _RECORD.finditer(low):
                    st.records[m.group(1)] = [(c.group(1).lower(), c.group(2)) for c in
                                              _COMPONENT.finditer(masked, m.start(2), m.end(2))]
            record_decl = None if not st.records else re.compile(
                r"\b(?:(?:LOCAL|TASK)\s+)?(?:CONST|PERS|VAR)\s+(" + "|".join(st.records) +
                r")\s+([A-Za-z]\w*)\s*(\{[^}]*\})?\s*:=", re.IGNORECASE)
            switches = [(c.start(), c.group(1), c.group(2) == "on") for c in _CONF.finditer(low)] \
                if "conf" in low else []
            conf = {"l": True, "j": True}
            k, n_sw = -1, 0
            for m in _STATEMENT.finditer(masked):  # ';' only ends statements: strings are masked
                s, e = m.span()
                while k + 1 < len(routines) and routines[k + 1][0] < e:
                    k += 1
                proc = routines[k][2] if k >= 0 and s < routines[k][1] else ""
                while n_sw < len(switches) and switches[n_sw][0] < e:
                    conf[switches[n_sw][1]] = switches[n_sw][2]
                    n_sw += 1
                r = record_decl.search(masked, s, e) if record_decl else None
                if r:
                    self._record(src, masked, r, e, st, src not in sources)
                else:
                    self._statement(src, masked, s, e, prog, st, src not in sources, proc, conf)
        for kind, decl, known in (("tool", st.tools, prog.tools), ("frame", st.wobjs, prog.frames)):
            for name, (pose, ok, why, *moved) in decl.items():
                if ok:
                    known[name] = pose
                    if moved and moved[0]:  # a work object a mechanical unit moves (ufmec)
                        prog.carried[name] = moved[0]
                        prog.warnings += [moved[1]] if moved[1] else []
                else:
                    prog.unsupported[f"{kind}:{name}"] = why
        for name in BUILTIN_TOOLS:
            prog.tools.setdefault(name, np.eye(4))
        for name in BUILTIN_WOBJS:
            prog.frames.setdefault(name, np.eye(4))
        prog.declared_tools, prog.declared_frames = dict(prog.tools), dict(prog.frames)
        prog.tools.update({self.name_key(k): v for k, v in tools.items()})
        prog.frames.update({self.name_key(k): v for k, v in frames.items()})
        self._assign(prog, st)
        _inactive_units(prog, lowered)
        flow.calls = [(src, at, name) for name, calls in st.calls.items() for src, at, *_ in calls]
        flow.entry = flow.routines.get("main")
        order_by_execution(prog, flow)
        return prog

    def _statement(self, src, masked, s, e, prog, st, only_frames, proc, conf):
        lead = _after_lead(masked, s, e)
        m = _DECL.search(masked, lead, e)  # after a PROC header: its PERS tooldata parameter is not one
        if m:
            kind, name = m.group(2).lower(), m.group(3)
            if m.group(5) is None:
                if kind == "robtarget":
                    st.declared.setdefault(name.lower(), [])  # VAR robtarget p; assigned at run time
                return
            shaped = _ROBTARGET.match(masked, m.end(), e) if kind == "robtarget" and not m.group(4) else None
            tree = None if shaped else parse_aggregate(src, masked, m.end(), e, f"{kind} {name}")[0]
            where = f"{src.path.name}:{src.line_of(m.start())}"
            if kind == "robtarget":
                first = st.places.setdefault((src.path, proc, name.lower()), m.start())
                if first != m.start():  # the controller refuses the module; one copy would stay as it is
                    raise DataError(f"{where}: robtarget {name} is declared twice in "
                                    f"{f'routine {proc}' if proc else 'the module'} (first at line "
                                    f"{src.line_of(first)}): give each target once")
                targets = [self._shaped(src, shaped, name, m.start())] if shaped else \
                    self._robtargets(src, tree, name, m.start(), m.group(4))
                holes = [t for t in targets if _placeholder(t)]  # pTemp := [[0,0,0],[0,0,0,0],...]
                for t in holes:
                    st.placeholders[t.name.lower()] = f"{src.path.name}:{t.line}"
                if holes and not only_frames:  # one warning per declaration (an array may hold dozens)
                    one = (f"{where}: robtarget {name} holds the quaternion [0,0,0,0]: a placeholder the "
                           "program assigns at run time, not a taught target: left as it is")
                    prog.warnings.append(one if not m.group(4) else (
                        f"{where}: {len(holes)} of the {len(targets)} elements of robtarget {name} "
                        f"({holes[0].name} ...) hold the quaternion [0,0,0,0]: placeholders the program "
                        "assigns at run time, not taught targets: left as they are"))
                targets = [t for t in targets if not _placeholder(t)]
                if only_frames:
                    for t in targets:
                        t.name += f" (in the reference {src.path.name})"
                st.declared[name.lower()] = targets
                st.reference |= {id(t) for t in targets} if only_frames else set()
                return
            for suffix, node in _elements(tree, m.group(4), src, m.start(), f"{kind} {name}"):
                st.data[(kind, name.lower() + suffix)] = _canonical(node)
                read = self._tool if kind == "tooldata" else self._wobj
                (st.tools if kind == "tooldata" else st.wobjs)[name.lower() + suffix] = read(
                    src, node, name + suffix, m.start(), where)
            return
        word = _WORD.match(masked, lead)
        mv = word if word and word.group(1).lower() in _MOVES else None
        if mv is None and word and word.group(1).upper() == "IF":  # IF condition MoveL ...; (no THEN)
            mv = _MOVE.search(masked, word.end(), e)
        if mv:
            positional, optional = _arguments(masked, mv.end(), e)
            instr, at = mv.group(1), mv.start(1)
            target_pos, tool_pos = _MOVES[instr.lower()]
            if len(positional) <= tool_pos:
                raise DataError(f"{src.path.name}:{src.line_of(at)}: {instr} has "
                                f"{len(positional)} arguments, expected at least {tool_pos + 1}")
            if "id" in optional and src.path not in st.multimove:
                st.multimove.add(src.path)
                prog.warnings.append(f"{src.path.name}:{src.line_of(at)}: MultiMove synchronized "
                                     "motions (\\ID): this task's robot is filtered with this calibration "
                                     "only; each robot of the cell needs its own calibration and filter run")
            joint = instr.lower().rstrip("sdoagync").endswith("j") or instr.lower() in ("triggjios", "spotj")
            st.motions.append(_Motion(instr, src, at, [positional[k] for k in target_pos],
                                      positional[tool_pos], optional.get("wobj"), proc,
                                      conf["j" if joint else "l"], "wobj?" in optional))
            return
        a = _ASSIGN.match(masked, lead + len(masked[lead:e]) - len(masked[lead:e].lstrip()), e)
        if a:
            name = a.group(1).lower()
            if a.group(3):
                st.modified.setdefault(name, []).append(f"{src.path.name}:{src.line_of(a.start())}")
                field = re.sub(r"\s+", "", a.group(3)).lower()
                if not field.startswith(_POSE_FREE):  # a tool's load: not where the TCP is
                    st.moved.setdefault(name, f"{src.path.name}:{src.line_of(a.start())}")
            else:
                st.assigned.setdefault(name, []).append((src, a.end(), e, proc))
            return
        c = re.match(r"\s*([A-Za-z]\w*)\b", masked[lead:e])
        if c and c.group(1).lower() in st.procs:
            positional, optional = _arguments(masked, lead + c.end(), e)
            st.calls.setdefault(c.group(1).lower(), []).append((src, lead + c.start(1), positional, optional,
                                                                 proc))
        elif c and masked[lead + c.end():e].strip():  # a routine of another module, or a built-in
            positional, _ = _arguments(masked, lead + c.end(), e)
            st.foreign.append((src, lead + c.start(1), c.group(1), positional))

    def _record(self, src, masked, m, e, st, only_frames):
        """A declaration of a RECORD type: its robtarget components become targets
        ``name{i}.field`` (the key ``name.field`` holds every element's)."""
        components = st.records[m.group(1).lower()]
        tree, _ = parse_aggregate(src, masked, m.end(), e, f"{m.group(1)} {m.group(2)}")
        for k, (kind, field) in enumerate(components):
            if kind != "robtarget":
                continue
            targets = []
            for suffix, node in _elements(tree, m.group(3), src, m.start(), f"{m.group(1)} {m.group(2)}"):
                if not (isinstance(node, list) and len(node) == len(components)):
                    raise DataError(f"{src.path.name}:{src.line_of(m.start())}: malformed {m.group(1)} "
                                    f"{m.group(2)}: expected {len(components)} components")
                at = _first_offset(node[k], m.start())
                t = self._robtarget(src, node[k], f"{m.group(2)}{suffix}.{field}", at)
                if _placeholder(t):  # a record's robtarget filled at run time
                    st.placeholders[f"{m.group(2).lower()}.{field.lower()}"] = f"{src.path.name}:{t.line}"
                else:
                    targets.append(t)
            st.declared[f"{m.group(2).lower()}.{field.lower()}"] = targets
            if only_frames:
                st.reference |= {id(t) for t in targets}

    def _robtarget(self, src, tree, name, at) -> Target:
        xyz, quat, conf = numbers_of(tree, (3, 4, 4), src, at, f"robtarget {name}")
        ext = tree[3] if len(tree) > 3 and isinstance(tree[3], list) else []
        axes = [(k, x.text) for k, x in enumerate(ext) if isinstance(x, Number)]
        return self._target(src, xyz + quat, conf, axes, name, at)

    def _shaped(self, src, m: re.Match, name, at) -> Target:
        """The target of a robtarget of numbers only, matched by ``_ROBTARGET``."""
        text, spans = src.text, m.regs
        numbers = [Number(a, b, text[a:b]) for a, b in spans[1:12]]
        axes = list(enumerate(text[a:b] for a, b in spans[12:18]))
        return self._target(src, numbers[:7], numbers[7:], axes, name, at)

    def _target(self, src, pose: list[Number], conf: list[Number], ext: list[tuple[int, str]], name,
                at) -> Target:
        """A robtarget's Target from its pose numbers, confdata and external axes ``(index, text)``."""
        config = [float(n.text) for n in conf]
        if not all(c.is_integer() and abs(c) < _CONF_LIMIT for c in config):
            raise DataError(f"{src.path.name}:{src.line_of(at)}: robtarget {name}: confdata must be "
                            f"integers, got {[n.text for n in conf]}")
        cf1, cf4, cf6, cfx = map(int, config)
        used = [(RAPID_EXTAX[k], x) for k, x in ext if abs(float(x)) < _UNUSED_AXIS]
        return Target(src, at, name, pose, config=np.array([cfx, cf1, cf4, cf6]), config_spans=conf,
                      external=", ".join(f"{k} = {x}" for k, x in used), axes={k: float(x) for k, x in used})

    def _robtargets(self, src, tree, name, at, array: str | None) -> list[Target]:
        return [self._robtarget(src, node, name + suffix, _first_offset(node, at) if array else at)
                for suffix, node in _elements(tree, array, src, at, f"robtarget {name}")]

    def _tool(self, src, tree, name, at, where):
        if not (isinstance(tree, list) and len(tree) >= 2 and isinstance(tree[0], Word)):
            raise DataError(f"{where}: malformed tooldata {name}: expected [robhold,[[x,y,z],[q]],[load]]")
        vals = [n.value for n in _pose_numbers(tree[1], src, at, f"tooldata {name}")]
        if not any(vals[3:]):  # [0,0,0,0]: filled at run time
            return np.eye(4), False, f"{where}: tooldata {name} {_EMPTY_DATA}"
        held = tree[0].text.upper() == "TRUE"
        return (self.to_pose(np.array([vals]))[0], held,
                f"{where}: tooldata {name} is a stationary tool (robhold FALSE)")

    def _wobj(self, src, tree, name, at, where):
        if not (isinstance(tree, list) and len(tree) >= 5 and isinstance(tree[0], Word)):
            raise DataError(f"{where}: malformed wobjdata {name}: expected "
                            "[robhold,ufprog,ufmec,[uframe],[oframe]]")
        uf, of = (np.array([[n.value for n in _pose_numbers(tree[k], src, at, f"wobjdata {name}")]])
                  for k in (3, 4))
        if not (any(uf[0, 3:]) and any(of[0, 3:])):  # a quaternion [0,0,0,0]: filled at run time
            return np.eye(4), False, f"{where}: wobjdata {name} {_EMPTY_DATA}", "", ""
        uf, of = self.to_pose(uf), self.to_pose(of)
        robhold, ufprog = (tree[0].text.upper() == "TRUE",
                           isinstance(tree[1], Word) and tree[1].text.upper() == "TRUE")
        unit = "" if robhold or ufprog or not isinstance(tree[2], Word) else \
            src.text[tree[2].start:tree[2].start + len(tree[2].text)].strip('"').strip()
        # a moving work object (ufprog FALSE): the controller defines its user frame by the unit (its
        # plate), continuously, and may store it in the PERS value: the targets are in oframe on the plate
        stored = ", ".join(f"{v:.1f}" for v in uf[0][:3, 3] * 1e3)
        note = f"{where}: wobjdata {name} moves with {unit}: its uframe ({stored} mm ...) is not used (the " \
            "controller defines a moving work object's user frame by the unit): its targets are taken in " \
            "oframe on the unit's plate" if unit and not np.allclose(uf[0], np.eye(4)) else ""
        why = f"{where}: wobjdata {name} is held by the robot (robhold TRUE)" if robhold else \
            f"{where}: wobjdata {name} moves with a unit it does not name (ufprog FALSE, ufmec '')"
        return of[0] if unit else uf[0] @ of[0], not robhold and (ufprog or bool(unit)), why, unit, note

    # ------------------------------------------------------------------ data flow
    def _assign(self, prog, st):
        """Follow each motion's target to the robtargets it comes from (through routine parameters,
        assignments, array indices, Offs/RelTool with constant offsets) and give each its tool
        and work object (one per target); name every motion that reaches a pose this cannot
        follow."""
        first = prog.used
        same, named = _same_data(prog, st), {}  # (target, data) -> the tool and wobj names of its first use
        for mv in st.motions:
            here = f"{mv.src.path.name}:{mv.src.line_of(mv.at)}"
            # a motion of a reference module is not one of the program's (never written, never
            # accounted): it only carries a program's target reached through its routine's parameter
            mine = mv.src.path not in st.read_only
            acc = prog.motion(mv.src, mv.at, mv.instr) if mine else None
            for scope in st.scopes(mv.proc):
                wobj_text = "" if mv.wobj is None else st.masked[mv.src.path][slice(*mv.wobj)].strip().lower()
                tool_text = st.masked[mv.src.path][slice(*mv.tool)].strip().lower()
                if _absent(scope.get(tool_text)) or (not mv.conditional and _absent(scope.get(wobj_text))):
                    continue  # an optional tool / \\WObj:=WObj this call leaves out: runs only when present
                tool, why_tool = st.name_of(mv.src, mv.tool, scope, "tool")
                wobj, why_wobj = ("wobj0", "") if mv.wobj is None or (
                    mv.conditional and _absent(scope.get(wobj_text))) else st.name_of(
                    mv.src, mv.wobj, scope, "work object")
                for a, b in mv.targets:
                    for found in self._follow(st, mv.src, a, b, mv.proc, scope, 0):
                        if not mine and (isinstance(found, str) or id(found) in st.reference):
                            continue  # the reference's own target or run-time pose: not the program's
                        if isinstance(found, str):
                            prog.skip(here, mv.instr, found, acc, st.masked[mv.src.path][a:b][:60])
                            if isinstance(found, RunTime) and not mv.conditional:  # --runtime-correction
                                # may route it (not with \\WObj?WObj: the routine takes a work object always)
                                prog.runtime_sites.append(self._site(st, mv, acc, a, b, tool, wobj))
                            continue
                        if why_tool or why_wobj:
                            prog.skip(here, mv.instr, why_tool or why_wobj, acc)
                            if mine and id(found) not in st.reference:  # its other motions: not corrected
                                prog.withhold(found, f"robtarget {found.name} is also moved to at {here}, "
                                                     f"where {why_tool or why_wobj}")
                            continue
                        if id(found) in st.reference:
                            prog.skip(here, mv.instr, f"{found.name.split(' (')[0]} is declared in "
                                                      f"{found.source.path.name}, given as a reference: give "
                                                      "that module as a program file to correct it", acc)
                            continue
                        label = f"robtarget {found.name.lower()}"
                        data = (id(found), same.get(("tooldata", tool), tool),
                                same.get(("wobjdata", wobj), wobj))
                        if prog.use(found, *named.setdefault(data, (tool, wobj)), here, label, "work object",
                                    (mv.src.path, a), acc):
                            found.monitored = mv.monitored
            if mine and not acc.targets and not acc.named:  # every call leaves out an optional parameter
                text = " ".join(st.masked[mv.src.path][slice(*mv.targets[-1])].split())
                prog.skip(here, mv.instr, f"{text}: the motion needs an optional parameter of routine "
                          f"{mv.proc} that no call in these files gives (it runs only when the parameter is "
                          "present)", acc, text)
        passed = set()
        for src, at, routine, positional in st.foreign:  # a robtarget given to a routine not in these files
            for a, b in positional:
                r = _REF.fullmatch(st.masked[src.path][a:b].strip())
                name = r.group(1).lower() if r and not r.group(3) else ""
                targets = st.declared.get(name)
                unused = targets and not any(id(t) in first for t in targets)
                if unused and id(targets[0]) not in st.reference:
                    prog.skip(f"{src.path.name}:{src.line_of(at)}", routine,
                              f"robtarget {r.group(1)} is passed to {routine}, a routine not in these files: "
                              "if it moves there, give its module as a program file")
                    passed.add(name)
        for key, targets in st.declared.items():
            if key in passed:
                continue
            if targets and not any(id(t) in first for t in targets) and id(targets[0]) not in st.reference:
                prog.warnings.append(f"{targets[0].source.path.name}:{targets[0].line}: robtarget "
                                     f"{targets[0].name.split('{')[0]} is not used by a motion instruction "
                                     "in these files: left as it is")

    @staticmethod
    def _site(st, mv, acc, a, b, tool, wobj) -> RuntimeSite:
        """The target argument ``a:b`` of motion ``mv`` (its tool and work object resolved to
        ``tool``, ``wobj``) as a run-time correction site."""
        masked = st.masked[mv.src.path]
        lead = a + len(masked[a:b]) - len(masked[a:b].lstrip())
        end = lead + len(masked[lead:b].rstrip())
        wobj_text = None if mv.wobj is None else masked[mv.wobj[0]:mv.wobj[1]].strip()
        return RuntimeSite(acc, mv.src.path, lead, end, masked[mv.tool[0]:mv.tool[1]].strip(), wobj_text,
                           tool, wobj)

    @staticmethod
    def _meant(st, src, span, base, scope) -> list[Meant]:
        """The base ``span`` of an Offs/RelTool as a :class:`Meant` use when it is a declared
        robtarget's bare name (not a routine parameter, never assigned, one target), else none."""
        masked = st.masked[src.path]
        text = masked[span[0]:span[1]]
        r = _REF.fullmatch(text.strip())
        if not r or r.group(2) or r.group(3) or len(base) != 1 or not isinstance(base[0], Target):
            return []
        name = r.group(1).lower()
        if name in scope or name in st.assigned or st.modified.get(name) or st.declared.get(name) != base:
            return []
        start = span[0] + len(text) - len(text.lstrip())
        return [Meant(base[0], src.path, start, start + len(text.strip()))]

    @staticmethod
    def _named_targets(st, text: str) -> list[Target]:
        """The declared robtargets named in ``text`` and in the bodies of the robtarget FUNCs of
        these files that it calls (what a value computed at run time from ``text`` depends on)."""
        words = {w.lower() for w in re.findall(r"[A-Za-z]\w*", text)}
        for body_of in st.functions:
            if body_of in words:
                words |= {w.lower() for w in re.findall(r"[A-Za-z]\w*", st.functions[body_of])}
        return [t for w in words for key, ts in st.declared.items()
                if key == w or key.startswith(w + "{") or key.startswith(w + ".") for t in ts]

    def _follow(self, st, src, a, b, proc, scope, depth) -> list:
        """The robtargets (Target) the expression ``src[a:b]`` takes its value from, or a string
        saying why a part of it cannot be followed."""
        masked = st.masked[src.path]
        text = masked[a:b].strip()
        lead = a + len(masked[a:b]) - len(masked[a:b].lstrip())
        if depth > _DEPTH:
            return [f"{text[:40]} is defined through more than {_DEPTH} assignments or calls"]
        if text.startswith("["):
            key = (src.path, lead)
            shaped = _ROBTARGET.match(masked, lead, b)
            if shaped:
                if key not in st.inline:
                    st.inline[key] = self._shaped(src, shaped, f"inline@{src.line_of(lead)}", lead)
                return [st.inline[key]]
            tree, _ = parse_aggregate(src, masked, lead, b, "robtarget")
            if isinstance(tree, list) and tree and isinstance(tree[0], list) and tree[0] \
                    and isinstance(tree[0][0], Number):
                named = [(k, part.text) for k, part in enumerate(tree[:4]) if isinstance(part, Word)]
                if named:  # e.g. RoboDK's [[x,y,z],[q..],conf,[eax..]]: a variable's value, not a literal
                    k, word = named[0]
                    return [f"the robtarget's {_COMPONENTS[k]} is the variable {word}: a target with a "
                            "variable part is not followed"]
                key = (src.path, lead)
                if key not in st.inline:
                    st.inline[key] = self._robtarget(src, tree, f"inline@{src.line_of(lead)}", lead)
                return [st.inline[key]]
            why = f"{text[:40]} is not a robtarget literal"
            return [RunTime(why, sources=self._named_targets(st, text))]
        f = _CALLED.match(masked, lead, b)
        if f:
            inner = split_top(masked, f.end(), close_bracket(masked, f.end() - 1))
            amounts = [masked[u:w].partition(":=")[2] if k else masked[u:w]  # RelTool's \Rx:= \Ry:= \Rz:=
                       for x, y in inner[1:] for k, (u, w) in enumerate(split_top(masked, x, y, "\\"))]
            varying = ", ".join(" ".join(v.split()) for v in amounts if _constant(v, st.constants) is None)
            if not varying:
                return self._follow(st, src, *inner[0], proc, scope, depth + 1)
            why = (f"{' '.join(text.split())[:60]} moves the target by amounts known at run time only "
                   f"({varying})")
            base = self._follow(st, src, *inner[0], proc, scope, depth + 1)
            return [merged(why, base, self._meant(st, src, inner[0], base, scope)) or why]
        f = _FUNCTION.match(masked, lead, b)
        if f:
            why = f"the target is computed at run time by {f.group(1)}()"
            if f.group(1).lower() in _REACHED:
                return [RunTime(why, relative=True)]
            return [RunTime(why, sources=self._named_targets(st, masked[f.end():b]))]
        r = _REF.fullmatch(text)
        if not r:
            return [f"{' '.join(text.split())[:40]} is not a robtarget this filter can follow"]
        name, index, fields = r.group(1).lower(), r.group(2), r.group(3)
        if name in scope:
            arg_src, x, y, caller, outer = scope[name]
            if _absent(scope[name]):  # left out by this call: the motion does not run with it
                return []
            if arg_src is None:
                return [f"{r.group(1)} is a parameter of routine {proc} that no call in these files gives"]
            return self._follow(st, arg_src, x, y, caller, outer, depth + 1)
        fields = re.sub(r"\s+", "", fields).lower() if fields else ""
        if fields and name + fields not in st.declared:
            return [f"{' '.join(text.split())} is a field of a RECORD or robtarget: its value is not "
                    "followed"]
        if st.modified.get(name):  # the pose reached is partly computed at run time
            return [RunTime(f"{r.group(1)} is modified at run time ({r.group(1)}.<field> := ... at "
                            f"{st.modified[name][0]})", sources=st.declared.get(name) or ())]
        out: list = []
        if name in st.assigned:
            for arg_src, x, y, where_proc in st.assigned[name]:
                scopes = [scope] if where_proc == proc else st.scopes(where_proc)
                for sc in scopes:
                    out += self._follow(st, arg_src, x, y, where_proc, sc, depth + 1)
            return out
        targets = st.declared.get(name + fields)
        if targets is None:
            return out + [Undeclared(f"robtarget {r.group(1)} is not declared in these files (give the "
                                     "module that declares it as a program file)", f"robtarget {r.group(1)}")]
        holes = [k for k in st.placeholders if k == name + fields or k.startswith(name + "{")]
        if index:
            literal = re.fullmatch(r"\{\s*(\d+(?:\s*,\s*\d+)*)\s*\}", index)
            if literal:
                want = name + "{" + ",".join(v.strip() for v in literal.group(1).split(",")) + "}" + fields
                chosen = [t for t in targets if t.name.split(" (")[0].lower() == want]
                if not chosen and want in st.placeholders:
                    return out + [_unfilled(f"{r.group(1)}{index}", st.placeholders[want])]
                return out + (chosen or [f"{r.group(1)}{index} is outside the array"])
        if holes:  # the placeholder (or an array's placeholder elements) has no value before run time
            return out + list(targets) + [_unfilled(text if not index else f"{r.group(1)}{{...}}",
                                                    st.placeholders[holes[0]])]
        if not targets:
            return out + [f"{r.group(1)} is declared without a value and not assigned in these files"]
        return out + list(targets)  # a variable index: every element of the array


class _Motion:
    """A motion instruction: its name, where, the spans of its target and tool arguments, the
    work object's text (None: wobj0), its routine, whether configuration is monitored and whether
    the work object is passed conditionally (``\\WObj?WObj``)."""

    def __init__(self, instr, src, at, targets, tool, wobj, proc, monitored, conditional=False):
        self.instr, self.src, self.at, self.targets = instr, src, at, targets
        self.tool, self.wobj, self.proc, self.monitored = tool, wobj, proc, monitored
        self.conditional = conditional  # \WObj?Param: wobj0 when the routine's Param is absent


class _State:
    """What the modules declare and do: robtargets, tools, work objects, routine parameters and
    calls, assignments, motions."""

    def __init__(self):
        self.masked: dict = {}
        self.declared: dict[str, list[Target]] = {}
        self.places: dict[tuple, int] = {}  # (path, routine, robtarget name) -> where it is declared
        self.tools: dict[str, tuple] = {}
        self.wobjs: dict[str, tuple] = {}
        self.reference: set[int] = set()
        self.read_only: set = set()  # the paths of the reference modules (read for their data only)
        self.procs: dict[str, list[tuple[str, bool]]] = {}  # name -> [(parameter, optional)]
        self.calls: dict[str, list] = {}  # name -> [(src, at, positional spans, optional, caller)]
        self.assigned: dict[str, list] = {}  # name -> [(src, start, end, routine)]
        self.modified: dict[str, list[str]] = {}  # name -> where a field of it is assigned
        self.moved: dict[str, str] = {}  # name -> where a field that places it (not a load) is assigned
        self.motions: list[_Motion] = []
        self.inline: dict = {}
        self.multimove: set = set()
        self.foreign: list = []  # (src, at, routine, positional spans): calls of routines not in these files
        self.constants: dict[str, float] = {}  # CONST num name -> value
        self.functions: dict[str, str] = {}  # FUNC robtarget name -> its body (lower case, masked)
        self.records: dict[str, list[tuple[str, str]]] = {}  # RECORD type -> [(type, field)]
        self.data: dict[tuple[str, str], tuple] = {}  # ('tooldata' | 'wobjdata', name) -> its value, as data
        self.placeholders: dict[str, str] = {}  # robtarget with the quaternion [0,0,0,0] -> where
        self._scopes: dict[str, list] = {}
        self._names: dict[tuple[str, str], tuple[str, str]] = {}  # (text, what) -> name_of outside parameters

    def scopes(self, proc: str, depth: int = 0) -> list[dict]:
        """Every binding of routine ``proc``'s parameters by the calls of these files: parameter
        -> (src, start, end, calling routine, its binding); [{}] for a routine without parameters."""
        if not self.procs.get(proc):
            return [{}]
        if proc in self._scopes:
            return self._scopes[proc]
        self._scopes[proc] = []  # a recursive routine: its own calls add nothing
        out = []
        for src, _, positional, optional, caller in self.calls.get(proc, []):
            if depth > _DEPTH:
                break
            for outer in self.scopes(caller, depth + 1):
                bound, k = {}, 0
                for name, is_optional in self.procs[proc]:
                    if is_optional:  # left out, or passed on (\\Via?Via) from an optional the caller lacks
                        span = optional.get(name)
                        passed = span and name + "?" in optional and _absent(
                            outer.get(self.masked[src.path][span[0]:span[1]].strip().lower()))
                        bound[name] = (src, *span, caller, outer) if span and not passed else \
                            (None, *ABSENT, caller, outer)
                    else:
                        bound[name] = (src, *positional[k], caller, outer) if k < len(positional) else \
                            (None, 0, 0, caller, outer)
                        k += 1
                out.append(bound)
        if not out:  # no call in these files: the parameters are unknown, the rest is followed
            out = [{name: (None, 0, 0, "", {}) for name, _ in self.procs[proc]}]
        self._scopes[proc] = out
        return out

    def name_of(self, src, span, scope, what: str) -> tuple[str, str]:
        """The tool or work object an argument names (following routine parameters), or why not."""
        masked = self.masked[src.path]
        text = masked[span[0]:span[1]].strip() if isinstance(span, tuple) else span
        if not scope:  # the same text names the same tool everywhere outside routine parameters
            key = (text, what)
            if key not in self._names:
                self._names[key] = self._name_of(text, src, scope, what)
            return self._names[key]
        return self._name_of(text, src, scope, what)

    def _name_of(self, text: str, src, scope, what: str) -> tuple[str, str]:
        r = _REF.fullmatch(text)
        if not r or r.group(3):
            return "", f"the {what} {' '.join(text.split())[:40]} is chosen at run time"
        name = r.group(1).lower()
        if name in scope:
            arg_src, x, y, _, outer = scope[name]
            if _absent(scope[name]):
                return "", f"the {what} {text} is an optional parameter that a call of its routine leaves out"
            if arg_src is None:
                return "", f"the {what} {text} is a routine parameter that no call in these files gives"
            return self.name_of(arg_src, (x, y), outer, what)
        written = self._written(name)
        if written:  # the data the controller uses are those of run time, not the declaration's
            return "", f"the {what} {text} is assigned at run time ({written})"
        index = r.group(2)
        if index:
            literal = re.fullmatch(r"\{\s*(\d+(?:\s*,\s*\d+)*)\s*\}", index)
            if not literal:
                return "", f"the {what} {text} is chosen at run time (a variable index)"
            name += "{" + ",".join(v.strip() for v in literal.group(1).split(",")) + "}"
        return name, ""

    def _written(self, name: str) -> str:
        """Where the tool / work object ``name`` (or a field or element of it) is assigned in a
        routine of these files ('' if nowhere): a work object found by a search (``obNew :=
        OFrameChange(...)``) or a TCP measured at run time."""
        if name in self.assigned:
            src, at, _, _ = self.assigned[name][0]
            return f"{src.path.name}:{src.line_of(at)}"
        return self.moved.get(name, "")


def _absent(binding: tuple | None) -> bool:
    """A parameter binding of an optional parameter that the call leaves out (:data:`ABSENT`)."""
    return binding is not None and binding[0] is None and binding[1:3] == ABSENT


def _canonical(node) -> tuple | float | str:
    """A declaration's value as data (numbers as floats, words upper case, strings as written):
    two tools or work objects with equal canonical values are the same data under two names."""
    if isinstance(node, list):
        return tuple(_canonical(n) for n in node)
    if isinstance(node, Number):
        return node.value
    return node.text.upper() if isinstance(node, Word) else repr(node)


def _same_data(prog: Program, st: _State) -> dict[tuple[str, str], str]:
    """``(kind, name) -> the first declared name with identical data`` for the tooldata / wobjdata
    declared twice under two names (every value equal, and equal as the filter uses them after
    ``--tool``/``--frame``; neither assigned in these files): a target used with both is one
    target, corrected once."""
    out, first = {}, {}
    for (kind, name), value in [*_builtin_data().items(), *st.data.items()]:
        known = prog.tools if kind == "tooldata" else prog.frames
        if name not in known or name in st.assigned or name in st.modified:
            continue  # not filtered (a stationary tool ...), or its value changes at run time
        head = first.setdefault((kind, value, prog.carried.get(name)), name)
        if head != name and np.array_equal(known[head], known[name]):
            out[(kind, name)] = head
    return out


@functools.cache
def _builtin_data() -> dict[tuple[str, str], tuple]:
    """:data:`_BUILTIN_DATA` as data (:func:`_canonical`), read as a module's declaration is."""
    out = {}
    for key, text in _BUILTIN_DATA.items():
        src = ProgramText(key[1], text.encode())
        masked = src.masked([COMMENT_RE], [STRING_RE])
        out[key] = _canonical(parse_aggregate(src, masked, 0, len(masked), key[1])[0])
    return out


def _placeholder(t: Target) -> bool:
    """A robtarget whose quaternion is [0,0,0,0]: no orientation at all, a placeholder the program
    fills at run time (``VAR robtarget pTemp := [[0,0,0],[0,0,0,0],...]``), not a taught target."""
    return all(n.value == 0.0 for n in t.numbers[3:7])


def _unfilled(text: str, where: str) -> str:
    """Why a motion to placeholder ``text`` (declared at ``where``) is not corrected."""
    return (f"{' '.join(text.split())} is a placeholder (declared at {where} with the quaternion [0,0,0,0]: "
            "not a taught target) that the program assigns at run time, and no assignment in these files "
            "gives it a value")


def _arguments(masked: str, start: int, end: int) -> tuple[list[tuple[int, int]], dict]:
    """Positional argument spans and optional ``\\Name:=value`` arguments (name -> value span, or
    the switch's own span) of an instruction whose arguments run from ``start`` to ``end``; a
    conditional ``\\Name?Param`` is ``name`` -> the span of ``Param``, and also ``name?``."""
    positional, optional = [], {}
    for ps, pe in split_top(masked, start, end, ","):
        parts = split_top(masked, ps, pe, "\\") if "\\" in masked[ps:pe] else [(ps, pe)]
        if masked[parts[0][0]:parts[0][1]].strip():
            named = _NAMED_ARG.match(masked, *parts[0])  # ToPoint:=p10: a required argument by name
            positional.append((named.end(), parts[0][1]) if named else parts[0])
        for os_, oe in parts[1:]:
            key, sep, _ = masked[os_:oe].partition(":=")
            if not sep and "?" in key:  # \Name?Param: given only when the routine's own Param is present
                name = key.partition("?")[0].strip().lower()
                optional[name] = optional[name + "?"] = (os_ + key.index("?") + 1, oe)
                continue
            value_at = os_ + len(key) + len(sep)
            optional[key.strip().lower()] = (value_at, oe) if sep else (os_, oe)
    return positional, optional


def _params(text: str) -> list[tuple[str, bool]]:
    """A routine's parameters ``(name, optional)`` from ``robtarget p, \\PERS tooldata t, ...``: an
    optional parameter begins with a backslash, with or without a comma before it (``PERS tooldata
    Tool\\robtarget Via``), and so does each alternative after a ``|`` (``\\switch On | switch Off``)."""
    pieces = re.split(r"([,|])", text.replace("\\", ",\\"))
    out, alternative = [], False
    for k in range(0, len(pieces), 2):
        words = re.findall(r"[A-Za-z]\w*", pieces[k])
        if words:
            out.append((words[-1].lower(), "\\" in pieces[k] or alternative))
        alternative = k + 1 < len(pieces) and pieces[k + 1] == "|"
    return out


def _elements(tree, dims: str | None, src, at, what):
    """``(index suffix, node)`` of a declaration's value: ``('', value)``, or for an array
    declared ``{n}`` / ``{n,m}`` (``dims``) each element ('{1}', '{2,1}' ...)."""
    if not dims:
        return [("", tree)]
    out = []

    def walk(node, index, levels):
        if not isinstance(node, list):
            raise DataError(f"{src.path.name}:{src.line_of(at)}: malformed {what} array")
        for i, child in enumerate(node):
            if levels > 1:
                walk(child, index + [i + 1], levels - 1)
            else:
                out.append(("{" + ",".join(map(str, index + [i + 1])) + "}", child))

    walk(tree, [], dims.count(",") + 1)
    return out


def _constant_key(text: str) -> str:
    """``name{1, 2}`` -> ``name__1_2`` (lower case): a constant array element as one name."""
    def joined(m: re.Match) -> str:
        return m.group(1) + "__" + "_".join(re.findall(r"\d+", m.group(2)))

    return _SUBSCRIPT.sub(joined, text).lower()


def _constant(text: str, constants: dict[str, float]) -> float | None:
    """The value of a RAPID num expression of numbers, CONST nums and their constant array
    elements (``nBead{1, 2} * ((-1) * K)``), else None."""
    return constant_value(_constant_key(text), constants)


def _inactive_units(prog: Program, lowered: dict) -> None:
    """Warn of each unit moving a work object the motions use that no ``ActUnit`` of these files
    activates (the controller moves such a work object only while its unit is active)."""
    active = {m.group(1) for low in lowered.values() for m in _ACTUNIT.finditer(low)}
    used = {prog.carried[t.frame] for t in prog.targets if t.frame in prog.carried}
    for unit in sorted(u for u in used if u.lower() not in active):
        prog.warnings.append(f"no ActUnit {unit} in these files: the work objects {unit} moves follow it "
                             "only while it is active (activated at start-up or by another module?)")


def _after_lead(masked: str, start: int, end: int) -> int:
    """Where a statement's instruction begins, after block keywords (PROC header, IF .. THEN ...)."""
    while True:
        k = _LEAD.match(masked, start, end)
        if not k or k.end() == start:
            return start
        start = k.end()
