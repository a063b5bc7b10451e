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

import re
from bisect import bisect_left

import numpy as np

from robocal.errors import DataError
from robocal.kinematics.transforms import make_transform, rotvec_to_matrix
from robocal.programs.aggregate import numbers_of, parse_aggregate, split_top
from robocal.programs.model import IDENTITY, Dialect, Program, Target
from robocal.programs.rotations import nearest_rotvec
from robocal.programs.source import Number, mask

_COMMENT = re.compile(r"#[^\n]*")
_STRING = re.compile(r"\"[^\"\n]*\"|'[^'\n]*'")
_POSE = re.compile(r"(?<![\w.])p\s*(?=\[)")
_ASSIGN = re.compile(r"(?:\b(?:global|local)\s+)?\b([A-Za-z_]\w*)\s*=\s*(?!=)")
_CALL = re.compile(r"\b(movel|movep|movec|movej|set_tcp)\s*\(")
_IDENT = re.compile(r"\s*([A-Za-z_]\w*)\s*$")
_POSE_TRANS = re.compile(r"\s*pose_trans\s*\(", re.IGNORECASE)
_IK = re.compile(r"\s*get_inverse_kin\s*\(")
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


def _close(masked: str, open_at: int) -> int:
    """Index of the bracket closing the one at ``open_at``."""
    depth = 0
    for i in range(open_at, len(masked)):
        if masked[i] in "([":
            depth += 1
        elif masked[i] in ")]":
            depth -= 1
            if depth == 0:
                return i
    raise DataError("unbalanced brackets")


class URScriptDialect(Dialect):
    name = "URScript"
    suffixes = (".script", ".urscript")
    scheme = None
    frame_help = "x,y,z in m and the rotation vector rx,ry,rz in rad, as in p[...]"

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
        prog = Program([], frames={IDENTITY: np.eye(4)}, tools={IDENTITY: np.eye(4)})
        user_default = tools.get(DEFAULT_TOOL, tools.get("", None))
        prog.tools.update(tools)
        if user_default is not None:
            prog.tools[DEFAULT_TOOL] = user_default
        order = [0]
        for src in sources:
            masked = mask(src.text, [_COMMENT], [_STRING])
            poses, joints = self._variables(src, masked)
            tool = DEFAULT_TOOL
            used: dict[int, tuple[str, str, str]] = {}  # id(target) -> (tool, frame, where)
            as_frame: set[int] = set()  # pose variables that serve as features
            for m in _CALL.finditer(masked):
                open_at = m.end() - 1
                close = _close(masked, open_at)
                args = split_top(masked, open_at + 1, close)
                here = f"{src.path.name}:{src.line_of(m.start())}"
                fn = m.group(1)
                if fn == "set_tcp":
                    a, b = args[0]
                    pm = _POSE.match(masked, a + len(masked[a:b]) - len(masked[a:b].lstrip()))
                    if pm:
                        tree, _ = parse_aggregate(src, masked, pm.end(), b, "set_tcp pose")
                        vals = [n.value for n in numbers_of([tree], (6,), src, a, "set_tcp pose")[0]]
                        tool = f"set_tcp@{src.line_of(m.start())}"
                        prog.tools[tool] = self.to_pose(np.array([vals]))[0]
                    else:
                        name = masked[a:b].strip()
                        tool = name if name in tools else f"?{name}"
                    continue
                n_targets = 2 if fn == "movec" else 1
                for a, b in args[:n_targets]:
                    self._target_arg(src, masked, (a, b), m.start(), (tool, here), poses, joints, prog,
                                     (used, as_frame), order)
            for t in poses.values():
                if id(t) not in used and id(t) not in as_frame:
                    prog.warnings.append(f"{t.where}: pose variable not used by a motion: left as it is")
        for t in prog.targets:
            if t.tool.startswith("?"):
                prog.unsupported[f"tool:{t.tool}"] = (f"set_tcp({t.tool[1:]}) is not a pose this filter can "
                                                      "read")
        if any(t.tool == DEFAULT_TOOL for t in prog.targets) and DEFAULT_TOOL not in prog.tools:
            prog.tools[DEFAULT_TOOL] = np.eye(4)
            prog.warnings.append("no set_tcp before the first motion and no --tool: the installation's "
                                 "TCP is taken as the flange (give it with --tool x,y,z,rx,ry,rz in m, rad)")
        prog.targets.sort(key=lambda t: t.order)
        return prog

    def _variables(self, src, masked):
        """Pose variables (a Target each) and joint-list variables (joints), in text order."""
        poses, joints = _Assignments(), _Assignments()
        for m in _ASSIGN.finditer(masked):
            rest = m.end()
            pm = _POSE.match(masked, rest)
            if pm:
                close = _close(masked, pm.end())
                tree, _ = parse_aggregate(src, masked, pm.end(), close + 1, f"pose {m.group(1)}")
                nums = numbers_of([tree], (6,), src, rest, f"pose {m.group(1)}")[0]
                poses.add(m.group(1), m.start(), Target(src, m.start(), m.group(1), nums))
            elif masked[rest:rest + 1] == "[":
                close = _close(masked, rest)
                tree, _ = parse_aggregate(src, masked, rest, close + 1, f"list {m.group(1)}")
                if len(tree) == 6 and all(isinstance(x, Number) for x in tree):
                    joints.add(m.group(1), m.start(), np.array([x.value for x in tree]))
        return poses, joints

    def _target_arg(self, src, masked, span, at, tool_here, poses, joints, prog, seen, order):
        """One target argument of a motion: record the Cartesian target it names, or the joints."""
        (a, b), (tool, here), (used, as_frame) = span, tool_here, seen
        text = masked[a:b]
        lead = a + len(text) - len(text.lstrip())
        frame, qnear = IDENTITY, None
        ik = _IK.match(masked, lead)
        if ik:
            inner = split_top(masked, ik.end(), _close(masked, ik.end() - 1))
            for qa, qb in inner[1:]:
                key, _, val = masked[qa:qb].partition("=")
                val = (val if key.strip() == "qnear" else masked[qa:qb]).strip()
                if val.startswith("["):
                    tree, _ = parse_aggregate(src, masked, masked.index("[", qa), qb, "qnear")
                    if len(tree) != 6 or not all(isinstance(x, Number) for x in tree):
                        raise DataError(f"{here}: qnear must be a list of 6 joint values")
                    qnear = np.array([x.value for x in tree], float)
                elif _IDENT.match(val):
                    qnear = joints.latest(val, at)
            a, b = inner[0]
            text = masked[a:b]
            lead = a + len(text) - len(text.lstrip())
        pt = _POSE_TRANS.match(masked, lead)
        if pt:
            inner = split_top(masked, pt.end(), _close(masked, pt.end() - 1))
            if len(inner) != 2:
                raise DataError(f"{here}: pose_trans takes two arguments (FEATURE, pose), got {len(inner)}: "
                                f"{' '.join(masked[lead:b].split())[:80]}")
            fname = masked[slice(*inner[0])].strip()
            if not _IDENT.match(fname):
                return
            frame = fname
            if fname not in prog.frames:
                ref = poses.latest(fname, at)
                if ref is not None:
                    prog.frames[fname] = self.to_pose(ref.values()[None])[0]
                    as_frame.add(id(ref))
            a, b = inner[1]
            text = masked[a:b]
            lead = a + len(text) - len(text.lstrip())
        if masked[lead:lead + 1] == "[":  # movej([...]): joints, left alone
            tree, _ = parse_aggregate(src, masked, lead, b, "joint target")
            if len(tree) == 6 and all(isinstance(x, Number) for x in tree):
                prog.joint_targets.append((order[0], np.array([x.value for x in tree])))
            return
        pm = _POSE.match(masked, lead)
        if pm:
            tree, _ = parse_aggregate(src, masked, pm.end(), b, "pose")
            nums = numbers_of([tree], (6,), src, lead, "pose")[0]
            t = Target(src, lead, f"p@{src.line_of(lead)}", nums)
        else:
            name = _IDENT.match(text)
            if not name:
                return
            q = joints.latest(name.group(1), at)
            if q is not None:
                prog.joint_targets.append((order[0], q))
                return
            t = poses.latest(name.group(1), at)
            if t is None:
                return
            if id(t) in used:
                if used[id(t)][:2] != (tool, frame):
                    first_tool, first_frame, first_at = used[id(t)]
                    raise DataError(f"{here}: {t.name} is used with tool {tool} and frame {frame}, but at "
                                    f"{first_at} with {first_tool} / {first_frame}: one corrected pose "
                                    "cannot serve both; assign a copy for each use")
                return
        used[id(t)] = (tool, frame, here)
        t.tool, t.frame, t.qnear, t.order = tool, frame, qnear, order[0]
        order[0] += 1
        prog.targets.append(t)
