"""URScript programs (.script, and the script a PolyScope .urp exports).

Pose literals ``p[x, y, z, rx, ry, rz]`` (m, rotation vector in rad) are targets when a motion
``movel``, ``movep``, ``movec`` (via and end poses) or ``movej`` takes them, directly, through a
variable (``[global|local] name = p[...]``, the last assignment before the motion in text
order), through ``pose_trans(FEATURE, pose)`` (the pose is in the feature's frame; FEATURE is a
pose variable of the script or ``--frame FEATURE=x,y,z,rx,ry,rz``) or through
``get_inverse_kin(pose, qnear=Q)``. ``set_tcp(p[...])`` sets the tool of the motions after it;
before any, the installation's TCP applies (``--tool x,y,z,rx,ry,rz``, m and rad; else the
flange, with a warning). Joint motions ``movej([...])`` are left alone and tell where the arm
is: URScript has no configuration data, the controller takes the solution nearest the current
joints (``qnear``), so each target is solved nearest the previous one.

Comments (``#`` to the end of the line) and strings are masked first.
"""

from __future__ import annotations

import ast
import re
from bisect import bisect_left

import numpy as np

from robocal.core.errors import DataError
from robocal.kinematics.transforms import invert_transform, make_transform, rotvec_to_matrix
from robocal.programs.aggregate import close_bracket, list_pattern, numbers_of, parse_aggregate, split_top
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.urscript import marker, simulated
from robocal.programs.dialects.urscript.campaign import urscript_program
from robocal.programs.dialects.urscript.loads import URScriptLoads
from robocal.programs.dialects.urscript.syntax import COMMENT_RE, STRING_RE
from robocal.programs.flow import Flow, Routine, order_by_execution
from robocal.programs.model import IDENTITY, Program, Target
from robocal.programs.motions import Undeclared
from robocal.programs.rotations import nearest_rotvec
from robocal.programs.runtime import ROUTINE_NAME, RunTime, RuntimeSite
from robocal.programs.source import Number

_POSE = re.compile(r"(?<![\w.])p\s*(?=\[)")
_SIX = list_pattern(6)  # a pose literal's six numbers
_ASSIGNED = re.compile(r"\b([A-Za-z_]\w*)\s*=\s*$")  # ``name =`` right before a literal
_ASSIGN = re.compile(r"(?:\b(?:global|local)\s+)?\b([A-Za-z_]\w*)\s*=\s*(?!=)")
_CALL = re.compile(r"\b(movel|movep|movec|movej|set_tcp)\s*\(")
_IDENT = re.compile(r"\s*([A-Za-z_]\w*)\s*$")
_IK = re.compile(r"\s*get_inverse_kin\s*\(")
_FUNCTION = re.compile(r"([A-Za-z_]\w*)\s*\(")
_DEF = re.compile(r"\bdef\s+([A-Za-z_]\w*)\s*\(([^)]*)\)\s*:")
_DEPTH = 12  # assignments and calls followed at most this deep
# functions whose pose arguments are followed, or that do not move the robot to a pose argument
_KNOWN = {"movel", "movep", "movec", "movej", "set_tcp", "pose_trans", "pose_add", "pose_inv", "pose_sub",
          "get_inverse_kin", "p", "def", "textmsg", "popup", "to_str", "str_cat", "pose_dist", "point_dist",
          "is_within_safety_limits", "get_forward_kin", "sleep", "sync", "socket_send_string", "while", "if",
          "elif", "len", "norm"}
# a value computed at run time (a reader's reason saying so) that the run-time correction may route
_RUN_TIME = re.compile(r"(?<!corrected )at run time")
# expressions whose value is a pose (the run-time correction wraps only those: a joint list is not)
_POSE_VALUED = re.compile(r"\s*(?:p\s*\[|(?:pose_trans|pose_add|pose_sub|pose_inv|interpolate_pose|"
                         r"get_actual_tcp_pose|get_target_tcp_pose|get_forward_kin)\s*\()")
# built-ins reading where the robot is: a pose computed from them is already in the corrected space
_RELATIVE = frozenset({"get_actual_tcp_pose", "get_target_tcp_pose", "get_forward_kin",
                       "get_actual_joint_positions", "get_target_joint_positions", "get_target_waypoint"})
_POSITION_M = 1e-6
_ROTVEC = 1e-7
DEFAULT_TOOL = "default"


class _Assignments:
    """Values assigned to variable names in text order; :meth:`latest` finds the last assignment
    before an offset by bisection (a PolyScope export holds one variable per waypoint)."""

    def __init__(self) -> None:
        self._offsets: dict[str, list[int]] = {}
        self._values: dict[str, list] = {}

    def add(self, name: str, offset: int, value) -> None:
        """Record ``name = value`` at ``offset`` (offsets increase per name)."""
        self._offsets.setdefault(name, []).append(offset)
        self._values.setdefault(name, []).append(value)

    def latest(self, name: str, before: int):
        """The value of the last assignment to ``name`` before ``before``, else None."""
        k = bisect_left(self._offsets.get(name, ()), before)
        return self._values[name][k - 1] if k else None

    def values(self) -> list:
        return [v for vals in self._values.values() for v in vals]


class URScriptDialect(Dialect):
    name = "URScript"
    key = "urscript"
    campaign_rank = 2
    campaign_refuses_tracks = True
    vendor = "Universal Robots"
    signature = r"^\s*def\s+\w+\s*\(.*\)\s*:|\bmove[ljpc]\s*\("
    length_unit = "m"
    angle_unit = "rad"
    campaign_format, campaign_suffix = "URScript", ".script"
    runtime_correction = "robocal.programs.dialects.urscript.runtime:URScriptRuntime"
    suffixes = (".script", ".urscript")
    scheme = None
    frame_help = "x,y,z in m and the rotation vector rx,ry,rz in rad, as in p[...]"

    def load_reader(self, tools, schedules):
        return URScriptLoads()

    def campaign_files(self, joints, robot, path, **options):
        return {str(path): urscript_program(joints, path.stem, **options)}

    def mark(self, text, body, note):
        return marker.mark(text, body, note)

    def test_program(self, folder, nominal, q, tool, frame, name, variables=False):
        return simulated.write_test_program(self, folder, nominal, q, tool, frame, name, variables)

    def to_pose(self, values):
        values = np.asarray(values, float)
        return make_transform(rotvec_to_matrix(values[:, 3:6]), values[:, :3])

    def from_pose(self, T, old):
        return np.hstack([T[:, :3, 3], nearest_rotvec(T[:, :3, :3], old[:, 3:6])])

    def resolutions(self):
        return np.array([_POSITION_M] * 3 + [_ROTVEC] * 3)

    def config_edits(self, target, new):
        return {}

    def parse(self, sources, frames, tools, references=()):
        prog = Program([], frames={IDENTITY: np.eye(4), **frames}, tools={IDENTITY: np.eye(4)})
        prog.declared_tools = dict(prog.tools)  # and each set_tcp's pose (_set_tcp)
        user_default = tools.get(DEFAULT_TOOL, tools.get("", None))
        prog.tools.update(tools)
        if user_default is not None:
            prog.tools[DEFAULT_TOOL] = user_default
        scripts = []
        for src in sources:
            masked = src.masked([COMMENT_RE], [STRING_RE])
            sc = _Script(self, src, masked, prog)
            tool = DEFAULT_TOOL
            used = prog.used
            for m in _CALL.finditer(masked):
                open_at = m.end() - 1
                close = close_bracket(masked, open_at)
                args = split_top(masked, open_at + 1, close)
                here = f"{src.path.name}:{src.line_of(m.start())}"
                fn = m.group(1)
                if fn == "set_tcp":
                    tool = self._set_tcp(sc, args[0], m.start(), tools)
                    continue
                n_targets = 2 if fn == "movec" else 1
                for a, b in args[:n_targets]:
                    for kind, value, frame, qnear in sc.resolve(a, b, m.start(), 0):
                        if kind == "joints":
                            prog.motions.append((src.path, a, value))
                            continue
                        acc = prog.motion(src, m.start(), fn)
                        if kind == "skip":
                            value = sc.run_time(value, a, b, m.start())
                            prog.skip(here, fn, value, acc, masked[a:b][:60])
                            if isinstance(value, RunTime):  # --runtime-correction may route it
                                prog.runtime_sites.append(sc.site(acc, a, b, tool))
                        elif kind == "pose":
                            prog.skip(here, fn, "the pose is computed from values this filter cannot rewrite "
                                                "(expressions or another function's result)", acc,
                                      masked[a:b][:60])
                        elif kind == "target" and prog.use(value, tool, frame, here, value.name, "frame",
                                                           (src.path, a), acc):
                            value.qnear = qnear
            scripts.append(sc)
            for t in list(prog.targets):
                if id(t) in sc.as_frame:  # a feature that a motion also moves to (with an offset)
                    prog.targets.remove(t)
                    why = (f"{t.name} serves as a feature (pose_trans) and as a target: correcting it would "
                           "move the poses in its frame")
                    prog.not_corrected[id(t)] = why
                    prog.skip(used[id(t)][2], "motion", why)
            unused = [t for t in sc.poses.values()
                      if id(t) in sc.variables and id(t) not in used and id(t) not in sc.as_frame]
            passed = sc.passed({t.name for t in unused})
            for name, where, fn in passed:  # given to a function of a URCap or of another file
                prog.skip(where, fn, f"{name} is passed to {fn}(), which this filter does not follow: if "
                                     "it moves there, the pose is not corrected")
            for t in unused:
                if t.name not in {name for name, _, _ in passed}:
                    prog.warnings.append(f"{t.where}: pose variable not used by a motion: left as it is")
        for t in prog.targets:
            if t.tool.startswith("?"):
                prog.unsupported[f"tool:{t.tool}"] = (f"set_tcp({t.tool[1:]}) is not a pose this filter can "
                                                      "read")
        default_used = any(t.tool == DEFAULT_TOOL for t in prog.targets)
        if user_default is not None and prog.targets and not default_used:  # the user's TCP, unused
            own = sorted({t.tool for t in prog.targets})
            named = ", ".join(own[:3]) + (" ..." if len(own) > 3 else "")
            prog.warnings.append(f"--tool (the installation's TCP) is not used: every corrected motion "
                                 f"follows the script's own set_tcp ({named}), which the controller moves "
                                 "with; give --tool NAME= for set_tcp(NAME) to replace one")
        if default_used:  # the installation's TCP, which the script does not hold: taken as the flange
            prog.declared_tools[DEFAULT_TOOL] = np.eye(4)
        if default_used and DEFAULT_TOOL not in prog.tools:
            prog.tools[DEFAULT_TOOL] = np.eye(4)
            prog.warnings.append("no set_tcp before the first motion and no --tool: the installation's "
                                 "TCP is taken as the flange (give it with --tool x,y,z,rx,ry,rz in m, rad)")
        order_by_execution(prog, _flow(scripts, prog))
        return prog

    def _set_tcp(self, sc, span, at, tools) -> str:
        """The tool name a ``set_tcp(...)`` sets (a pose it can read is registered)."""
        a, b = span
        found = sc.resolve(a, b, at, 0)
        text = " ".join(sc.masked[a:b].split())
        if len(found) == 1 and found[0][0] in ("target", "pose") and found[0][2] == IDENTITY:
            pose = found[0][1] if found[0][0] == "pose" else self.to_pose(found[0][1].values()[None])[0]
            if found[0][0] == "target":
                sc.as_frame.add(id(found[0][1]))
            if text in tools:  # --tool NAME= for set_tcp(NAME): the user's, compared with the script's
                sc.prog.declared_tools.setdefault(text, pose)
                return text
            name = f"set_tcp@{sc.src.line_of(at)}"
            sc.prog.tools[name] = sc.prog.declared_tools[name] = pose
            return name
        return text if text in tools else f"?{text}"

class _Script:
    """One script's assignments in text order and the resolution of a motion's argument to the
    targets (literal poses) it comes from."""

    def __init__(self, dialect, src, masked, prog):
        self.d, self.src, self.masked, self.prog = dialect, src, masked, prog
        self.assigned = _Assignments()  # name -> (start, end) of the value assigned
        self.poses: dict[int, Target] = {}  # offset of a literal pose -> its target
        self.as_frame: set[int] = set()
        self.variables: set[int] = set()  # targets assigned to a variable (unused ones are named)
        self.params: list[tuple[int, str, list[str]]] = []  # (offset, def name, parameters)
        self.calls: dict[str, list[tuple[int, list]]] = {}
        literals = []
        for m in _ASSIGN.finditer(masked):
            if _before(masked, m.start()) in ("(", ","):
                continue  # a keyword argument: movel(p, a=1.2, v=0.25)
            end = _statement_end(masked, m.end())
            self.assigned.add(m.group(1), m.start(), (m.end(), end))
            value_at = m.end() + len(masked[m.end():end]) - len(masked[m.end():end].lstrip())
            if _POSE.match(masked, value_at):
                literals.append((value_at, end))
        for m in _DEF.finditer(masked):
            names = [x.strip() for x in m.group(2).split(",") if x.strip()]
            if names:
                self.params.append((m.start(), m.group(1), names))
        self.defs = definitions(masked)  # (name, start, end) of every def
        defined = {name for name, _, _ in self.defs}
        for m in re.finditer(r"\b([A-Za-z_]\w*)\s*\(", masked) if defined else ():
            if m.group(1) in defined and not masked[max(0, m.start() - 4):m.start()].endswith("def "):
                args = split_top(masked, m.end(), close_bracket(masked, m.end() - 1))
                self.calls.setdefault(m.group(1), []).append((m.start(), args))
        for a, b in literals:  # every pose variable is a target, used or not
            found = self._literal(a, b)
            if found[0] == "target":
                self.variables.add(id(found[1]))

    def number(self, text: str, at: int, depth: int) -> float | None:
        """The value of a constant numeric expression (numbers, + - * /, pi, sqrt/sin/cos/d2r and
        variables last assigned such a value before ``at``), else None."""
        try:
            tree = ast.parse(text.strip(), mode="eval")
        except (SyntaxError, RecursionError, MemoryError):  # deep nesting
            return None

        def ev(node):
            if isinstance(node, ast.Constant) and isinstance(node.value, int | float):
                return float(node.value)
            if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
                v = ev(node.operand)
                return -v if isinstance(node.op, ast.USub) else v
            if isinstance(node, ast.BinOp) and type(node.op) in _ARITHMETIC:
                return _ARITHMETIC[type(node.op)](ev(node.left), ev(node.right))
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FUNCTIONS \
                    and len(node.args) == 1:
                return _FUNCTIONS[node.func.id](ev(node.args[0]))
            if isinstance(node, ast.Name):
                if node.id == "pi":
                    return np.pi
                span = self.assigned.latest(node.id, at)
                if depth > _DEPTH:
                    raise ValueError(node.id)
                if span is None:  # a function's parameter: the value every call gives, if one
                    given = {self.number(self.masked[a:b], call_at, depth + 1)
                             for call_at, (a, b) in self._arguments(node.id, at)}
                    if len(given) != 1 or None in given:
                        raise ValueError(node.id)
                    return given.pop()
                v = self.number(self.masked[span[0]:span[1]], span[0], depth + 1)
                if v is None:
                    raise ValueError(node.id)
                return v
            raise ValueError(ast.dump(node)[:40])

        try:
            v = ev(tree.body)
        except (ValueError, ZeroDivisionError, TypeError, OverflowError, RecursionError):  # 10**400: no value
            return None
        return v if np.isfinite(v) else None

    def resolve(self, a: int, b: int, at: int, depth: int) -> list[tuple]:
        """What the expression ``masked[a:b]`` (evaluated at offset ``at``) moves to, as
        ``(kind, value, frame, qnear)``: 'target' (a literal pose to rewrite), 'pose' (a constant
        4x4 not written as literal numbers), 'joints', or 'skip' (value: why)."""
        masked = self.masked
        text = masked[a:b]
        lead = a + len(text) - len(text.lstrip())
        b = lead + len(text.strip())
        text = masked[lead:b]
        if depth > _DEPTH:
            return [("skip", f"{text[:40]} is defined through more than {_DEPTH} assignments", IDENTITY,
                     None)]
        ik = _IK.match(masked, lead)
        if ik:
            inner = split_top(masked, ik.end(), close_bracket(masked, ik.end() - 1))
            qnear = None
            for qa, qb in inner[1:]:
                key, eq, _ = masked[qa:qb].partition("=")
                start = qa + len(key) + len(eq) if key.strip() == "qnear" else qa
                found = self.resolve(start, qb, at, depth + 1)
                for kind, value, _, _ in found:
                    if kind == "joints":
                        qnear = value
                if masked[start:qb].strip().startswith("[") and not any(k == "joints" for k, *_ in found):
                    raise DataError(f"{self.src.path.name}:{self.src.line_of(start)}: qnear must be a list "
                                    f"of 6 joint values, got {' '.join(masked[start:qb].split())[:60]}")
            return [(k, v, f, qnear if k == "target" else q) for k, v, f, q in
                    self.resolve(*inner[0], at, depth + 1)]
        call = _FUNCTION.match(masked, lead)
        if call and call.group(1) in ("pose_trans", "pose_add"):
            inner = split_top(masked, call.end(), close_bracket(masked, call.end() - 1))
            if len(inner) != 2:
                return [("skip", f"{call.group(1)} takes two arguments (a missing comma?), got {len(inner)}",
                         IDENTITY, None)]
            first = self.resolve(*inner[0], at, depth + 1)
            second = self.resolve(*inner[1], at, depth + 1)
            return self._compose(call.group(1), first, second, masked[slice(*inner[0])].strip())
        if call and call.group(1) == "pose_inv":
            inner = split_top(masked, call.end(), close_bracket(masked, call.end() - 1))
            found = self.resolve(*inner[0], at, depth + 1) if len(inner) == 1 else []
            if len(found) == 1 and found[0][0] in ("pose", "target") and found[0][2] == IDENTITY:
                return [("pose", invert_transform(self._pose(found[0])), IDENTITY, None)]
        if call and call.group(1) == ROUTINE_NAME:  # a program robocal filtered with --runtime-correction
            return [("skip", f"already corrected at run time by robocal's {ROUTINE_NAME}", IDENTITY, None)]
        if call and call.group(1) != "p":
            return [("skip", f"the pose is computed at run time by {call.group(1)}()", IDENTITY, None)]
        if _POSE.match(masked, lead):
            return [self._literal(lead, b)]
        if text.startswith("["):
            try:
                tree, _ = parse_aggregate(self.src, masked, lead, b, "joint target")
            except DataError:
                tree = None
            if isinstance(tree, list) and len(tree) == 6 and all(isinstance(x, Number) for x in tree):
                return [("joints", np.array([x.value for x in tree]), IDENTITY, None)]
            values = [self.number(masked[x:y], at, depth) for x, y in split_top(masked, lead + 1, b - 1)]
            if len(values) == 6 and all(v is not None for v in values):
                return [("joints", np.array(values), IDENTITY, None)]
            return [("skip", f"{' '.join(text.split())[:50]} is a list computed at run time", IDENTITY, None)]
        name = _IDENT.match(text)
        if not name:
            return [("skip", f"{' '.join(text.split())[:50]} is not a pose this filter can follow", IDENTITY,
                     None)]
        ident = name.group(1)
        span = self.assigned.latest(ident, at)
        if span is None:
            param = self._parameter(ident, at, depth)
            if param is not None:
                return param
            return [("skip", Undeclared(f"{ident} is not assigned a pose before this motion in this script",
                                        f"the pose variable {ident}"), IDENTITY, None)]
        return self.resolve(span[0], span[1], span[0], depth + 1)

    def _literal(self, lead: int, b: int) -> tuple:
        """A ``p[...]`` literal: a target when its items are numbers, a constant pose when they
        are constant expressions, else a skip."""
        masked = self.masked
        pm = _POSE.match(masked, lead)
        if lead in self.poses:
            return ("target", self.poses[lead], IDENTITY, None)
        close = close_bracket(masked, pm.end())
        six = _SIX.match(masked, pm.end(), close + 1)  # six numbers: one match
        try:
            nums = [Number(a, b, self.src.text[a:b]) for a, b in six.regs[1:]] if six else numbers_of(
                [parse_aggregate(self.src, masked, pm.end(), close + 1, "pose")[0]], (6,), self.src, lead,
                "pose")[0]
        except DataError:  # not six literal numbers: expressions, perhaps constant ones
            nums = None
        if nums is not None:
            t = self.poses[lead] = Target(self.src, lead, self._name_at(lead), nums)
            return ("target", t, IDENTITY, None)
        texts = [masked[x:y].strip() for x, y in split_top(masked, pm.end() + 1, close)]
        values = [self.number(t, lead, 0) for t in texts]
        if len(values) == 6 and all(v is not None for v in values):
            return ("pose", self.d.to_pose(np.array([values]))[0], IDENTITY, None)
        varying = ", ".join(t for t, v in zip(texts, values, strict=False) if v is None)
        return ("skip", f"p[...] holds values known at run time only ({varying[:60]})", IDENTITY, None)

    def run_time(self, why, a: int, b: int, at: int):
        """``why`` as a :class:`RunTime` reason when the motion argument ``masked[a:b]`` at offset
        ``at`` is a pose (literal or pose built-in, through variables) computed at run time; else
        ``why`` as it is."""
        if isinstance(why, Undeclared) or not _RUN_TIME.search(str(why)):
            return why
        final = self._final(a, b, at, 0)
        if final is None or not _POSE_VALUED.match(self.masked, final[0]):
            return why
        targets, functions = {}, set()
        self._closure(a, b, at, 0, targets, functions)
        return RunTime(str(why), relative=bool(functions & _RELATIVE), sources=list(targets.values()))

    def site(self, acc, a: int, b: int, tool: str) -> RuntimeSite:
        """The motion argument ``a:b`` as a run-time correction site: the routine reads the active
        TCP from the controller and URScript poses are in the base frame (tool and frame known)."""
        lead = a + len(self.masked[a:b]) - len(self.masked[a:b].lstrip())
        end = lead + len(self.masked[lead:b].rstrip())
        return RuntimeSite(acc, self.src.path, lead, end, tool, None, IDENTITY, IDENTITY)

    def _final(self, a: int, b: int, at: int, depth: int) -> tuple[int, int] | None:
        """The span of the expression a plain variable ``masked[a:b]`` holds at ``at``, followed
        through assignments (the span itself when it is not a name; None: not assigned here)."""
        name = _IDENT.match(self.masked[a:b])
        if not name:
            return a, b
        span = self.assigned.latest(name.group(1), at)
        if span is None or depth > _DEPTH:
            return None
        return self._final(span[0], span[1], span[0], depth + 1)

    def _closure(self, a: int, b: int, at: int, depth: int, targets: dict, functions: set) -> None:
        """The literal targets (``targets``: id -> Target) and the functions (``functions``) the
        expression ``masked[a:b]`` at ``at`` is computed from, through the variables it reads."""
        if depth > _DEPTH:
            return
        masked = self.masked
        for m in _POSE.finditer(masked, a, b):
            found = self._literal(m.start(), close_bracket(masked, m.end()) + 1)
            if found[0] == "target":
                targets[id(found[1])] = found[1]
        for m in re.finditer(r"\b([A-Za-z_]\w*)\b(\s*\()?", masked[a:b]):
            if m.group(2):
                functions.add(m.group(1))
                continue
            span = self.assigned.latest(m.group(1), at)
            if span is not None:
                self._closure(span[0], span[1], span[0], depth + 1, targets, functions)

    def passed(self, variables: set[str]) -> list[tuple[str, str, str]]:
        """``(variable, where, function)`` for each of ``variables`` given as an argument to a
        function that is not a motion, a pose operation or a function of this script."""
        if not variables:
            return []
        out = []
        defined = {name for _, name, _ in self.params}
        for m in re.finditer(r"\b([A-Za-z_]\w*)\s*\(", self.masked):
            if m.group(1) in _KNOWN or m.group(1) in defined:
                continue
            for a, b in split_top(self.masked, m.end(), close_bracket(self.masked, m.end() - 1)):
                name = self.masked[a:b].strip()
                if name in variables:
                    out.append((name, f"{self.src.path.name}:{self.src.line_of(m.start())}", m.group(1)))
        return out

    def _pose(self, found: tuple) -> np.ndarray:
        """The 4x4 of a resolved 'pose' or 'target' (its numbers as written)."""
        return found[1] if found[0] == "pose" else self.d.to_pose(found[1].values()[None])[0]

    def _name_at(self, lead: int) -> str:
        """The variable a literal pose is assigned to (``name = p[...]``), else ``p@line``."""
        before = self.masked[max(0, lead - 80):lead]
        m = _ASSIGNED.search(before)
        return m.group(1) if m else f"p@{self.src.line_of(lead)}"

    def _compose(self, fn: str, first: list, second: list, first_text: str) -> list:
        """``pose_trans(A, B)`` / ``pose_add(A, B)``: B a literal target in frame A (pose_trans
        with A a fixed feature), or A a target moved by a constant B; else a skip."""
        out = []
        for kind_b, value_b, frame_b, _ in second:
            if kind_b == "target" and fn == "pose_trans" and frame_b != IDENTITY:  # a frame in a frame
                if len(first) == 1 and first[0][0] in ("pose", "target") and first[0][2] == IDENTITY:
                    frame = f"{first_text}*{frame_b}"
                    self.prog.frames.setdefault(frame, self._pose(first[0]) @ self.prog.frames[frame_b])
                    if first[0][0] == "target":
                        self.as_frame.add(id(first[0][1]))
                    out.append(("target", value_b, frame, None))
                else:
                    out.append(("skip", f"{fn}({first_text}, ...): the outer frame is not a pose this filter "
                                        "can read", IDENTITY, None))
            elif kind_b == "target" and fn == "pose_trans" and frame_b == IDENTITY:
                if first_text in self.prog.frames:
                    if len(first) == 1 and first[0][0] in ("pose", "target") and first[0][2] == IDENTITY:
                        self.prog.declared_frames.setdefault(first_text, self._pose(first[0]))  # --frame's
                    out.append(("target", value_b, first_text, None))
                elif len(first) == 1 and first[0][0] in ("pose", "target") and first[0][2] == IDENTITY:
                    pose = self._pose(first[0])
                    frame = first_text if _IDENT.match(first_text) else f"pose@{value_b.line}"
                    self.prog.frames.setdefault(frame, pose)
                    if first[0][0] == "target":
                        self.as_frame.add(id(first[0][1]))
                    out.append(("target", value_b, frame, None))
                else:
                    runtime = [v for k, v, _, _ in first if k == "skip"]
                    why = (f"relative to a pose known at run time only ({runtime[0]})" if runtime else
                           f"the feature {first_text} is not a pose this filter can read (give it with "
                           "--frame NAME=...)")
                    out.append(("skip", f"{fn}({first_text}, ...): {why}", IDENTITY, None))
            elif kind_b == "pose":
                for kind_a, value_a, frame_a, q in first:  # A moved by a constant offset: a use of A
                    out.append((kind_a, value_a, frame_a, q) if kind_a != "joints" else
                               ("skip", f"{fn} of a joint list", IDENTITY, None))
            elif kind_b == "skip":
                moved = [v.name for k, v, _, _ in first if k == "target"] or [first_text]
                out.append(("skip", f"{fn}({', '.join(moved)}, ...) moves it at run time: {value_b}",
                            IDENTITY, None))
            else:
                out.append(("skip", f"{fn}: the second pose is neither a literal nor a constant", IDENTITY,
                            None))
        return out

    def _arguments(self, ident: str, at: int) -> list[tuple[int, tuple[int, int]]]:
        """``(call offset, argument span)`` of every call passing parameter ``ident`` of the
        function whose definition with that parameter comes last before ``at`` ([] if none)."""
        for start, fn, names in reversed(self.params):
            if start < at and ident in names:
                k = names.index(ident)
                return [(call_at, args[k]) for call_at, args in self.calls.get(fn, []) if k < len(args)]
        return []

    def _parameter(self, ident: str, at: int, depth: int) -> list | None:
        """``ident`` as a parameter of a function: what every call of the function passes (None:
        not a parameter)."""
        for start, fn, names in reversed(self.params):
            if start < at and ident in names:
                out = []
                for call_at, span in self._arguments(ident, at):
                    out += self.resolve(*span, call_at, depth + 1)
                return out or [("skip", f"{ident} is a parameter of {fn}, which no call in this script "
                                        "gives", IDENTITY, None)]
        return None


_ARITHMETIC = {ast.Add: lambda x, y: x + y, ast.Sub: lambda x, y: x - y, ast.Mult: lambda x, y: x * y,
               ast.Div: lambda x, y: x / y}
_FUNCTIONS = {"sqrt": np.sqrt, "sin": np.sin, "cos": np.cos, "tan": np.tan, "d2r": np.deg2rad,
              "r2d": np.rad2deg, "norm": abs}


_BLOCK = re.compile(r"\b(def|thread|if|while|end)\b")


def definitions(masked: str) -> list[tuple[str, int, int]]:
    """``(name, start, end)`` of every ``def`` (end: after its ``end``; the file's end if the
    blocks do not balance). ``def``, ``thread``, and ``if``/``while`` beginning a statement open a
    block; ``end`` closes one."""
    out, stack = [], []
    for m in _BLOCK.finditer(masked):
        word = m.group(1)
        if word == "end":
            if stack:
                name, start = stack.pop()
                if name is not None:
                    out.append((name, start, m.end()))
        elif word in ("def", "thread"):
            d = _DEF.match(masked, m.start()) if word == "def" else None
            stack.append((d.group(1) if d else None, m.start()))
        elif _before(masked, m.start()) in ("", "\n", ":", ";"):
            stack.append((None, m.start()))
    out += [(name, start, len(masked)) for name, start in stack if name is not None]
    return sorted(out, key=lambda d: d[1])


def _flow(scripts: list[_Script], prog: Program) -> Flow:
    """The scripts' functions and calls; the entry (one script): its top-level statements when a
    motion or a call stands there, else its one top-level def that no call runs."""
    flow = Flow()
    for sc in scripts:
        for name, start, end in sc.defs:
            flow.routines[name] = Routine(name, sc.src, start, end)
        flow.calls += [(sc.src, at, name) for name, found in sc.calls.items() for at, _ in found]
    if len(scripts) != 1:
        return flow
    sc = scripts[0]
    top = [(start, end) for _, start, end in sc.defs
           if not any(s < start and end <= e for _, s, e in sc.defs)]
    inside = [at for _, at, _ in prog.motions] + [at for _, at, _ in flow.calls]
    if any(not any(s <= at < e for s, e in top) for at in inside):
        flow.entry = Routine("", sc.src, 0, len(sc.masked))
        return flow
    called = {name for _, _, name in flow.calls}
    uncalled = [name for name, start, _ in sc.defs if (start, flow.routines[name].end) in top
                and name not in called]
    if len(uncalled) == 1:
        flow.entry = flow.routines[uncalled[0]]
    return flow


def _before(masked: str, at: int) -> str:
    """The last character before ``at`` that is not a space or tab ('' at the start)."""
    i = at - 1
    while i >= 0 and masked[i] in " \t":
        i -= 1
    return masked[i] if i >= 0 else ""


def _statement_end(masked: str, start: int) -> int:
    """End of the value assigned at ``start``: the end of the line, brackets balanced."""
    depth = 0
    for i in range(start, len(masked)):
        ch = masked[i]
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        elif ch == "\n" and depth <= 0:
            return i
    return len(masked)
