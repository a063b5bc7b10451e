"""ABB RAPID modules (.mod, .modx, .prg, .sys).

* ``robtarget`` = ``[[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax_a,...,eax_f]]``: mm, unit
  quaternion w-first, configuration (see :class:`robocal.programs.config.ABBConfig`), external
  axes (left alone). Declared ``CONST``/``PERS``/``VAR`` (also ``LOCAL``/``TASK``, arrays
  ``name{n}`` / ``name{n,m}``) or written inline in a motion instruction.
* ``tooldata`` = ``[robhold,[[x,y,z],[q1..q4]],[load...]]``: TCP = flange * tframe.
* ``wobjdata`` = ``[robhold,ufprog,ufmec,[[uframe]],[[oframe]]]``: target pose in the world
  (= robot base) frame = uframe * oframe * robtarget.
* Motion instructions and the positions of their arguments (optional ``\\Arg`` removed):
  MoveL/MoveJ and their DO/AO/GO/Sync forms: ToPoint, Speed, Zone, Tool; MoveC: CirPoint,
  ToPoint, Speed, Zone, Tool; TriggL/TriggJ: ToPoint, Speed, Trigg, Zone, Tool; TriggC: CirPoint,
  ToPoint, Speed, Trigg, Zone, Tool; SearchL: Signal, SearchPoint (an output: left alone),
  ToPoint, Speed, Tool; SearchC: Signal, SearchPoint, CirPoint, ToPoint, Speed, Tool. The work
  object is ``\\WObj:=name`` (default wobj0). ``Offs(p, ...)`` and ``RelTool(p, ...)`` count as
  uses of ``p``. ``MoveAbsJ`` (jointtarget) and every other instruction are left alone.

Comments (``!`` to the end of the line) and strings are masked before anything is searched.
"""

from __future__ import annotations

import re

import numpy as np

from robocal.errors import DataError
from robocal.kinematics.transforms import make_transform
from robocal.programs.aggregate import Word, numbers_of, parse_aggregate, split_top
from robocal.programs.config import ABBConfig
from robocal.programs.model import Dialect, Program, Target
from robocal.programs.rotations import matrix_to_quat, quat_to_matrix
from robocal.programs.source import Number, ProgramText, mask

_COMMENT = re.compile(r"![^\n]*")
_STRING = re.compile(r'"(?:[^"\n]|"")*"')
_DECL = re.compile(r"\b(?:(?:LOCAL|TASK)\s+)?(CONST|PERS|VAR)\s+(robtarget|tooldata|wobjdata)\s+"
                   r"([A-Za-z]\w*)\s*(\{[^}]*\})?\s*(:=)?", re.IGNORECASE)
# instruction -> (positions of the robtarget arguments, position of the tool argument)
_MOVES = {"movel": ((0,), 3), "movej": ((0,), 3), "movec": ((0, 1), 4),
          "triggl": ((0,), 4), "triggj": ((0,), 4), "triggc": ((0, 1), 5),
          "searchl": ((2,), 4), "searchc": ((2, 3), 5)}
for _base, _spec in (("movel", ((0,), 3)), ("movej", ((0,), 3)), ("movec", ((0, 1), 4))):
    for _suffix in ("do", "ao", "go", "sync"):
        _MOVES[_base + _suffix] = _spec
_MOVE = re.compile(r"\b(" + "|".join(_MOVES) + r")\b", re.IGNORECASE)
_STATEMENT = re.compile(r"[^;]+")
_NAME = re.compile(r"\s*([A-Za-z]\w*)\s*(\{[^}]*\})?\s*$")
_ANY_ROBTARGET = re.compile(r"\brobtarget\s+([A-Za-z]\w*)", re.IGNORECASE)  # declarations and parameters
_FUNC = re.compile(r"\s*(?:Offs|RelTool)\s*\(\s*([A-Za-z]\w*)", re.IGNORECASE)
_POSITION_MM = 1e-3  # mm: 1 um
_QUATERNION = 1e-7
BUILTIN_TOOLS = ("tool0",)
BUILTIN_WOBJS = ("wobj0",)


def _pose_numbers(node, src, at, what) -> list[Number]:
    xyz, quat = numbers_of(node, (3, 4), src, at, what)
    return xyz + quat


class RapidDialect(Dialect):
    name = "ABB RAPID"
    suffixes = (".mod", ".modx", ".prg", ".sys")
    scheme = ABBConfig()
    n_values = 7
    frame_help = "x,y,z in mm and the quaternion q1,q2,q3,q4 (w first), as in tooldata/wobjdata"

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
        return np.hstack([T[:, :3, 3] * 1e3, matrix_to_quat(T[:, :3, :3], old[:, 3:7])])

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
        declared: dict[str, list[Target]] = {}
        tool_decl: dict[str, tuple[np.ndarray, bool, str]] = {}
        wobj_decl: dict[str, tuple[np.ndarray, bool, str]] = {}
        uses: list[tuple[str, Target | None, str, str, int, ProgramText]] = []
        for src in [*references, *sources]:
            masked = mask(src.text, [_COMMENT], [_STRING])
            only_frames = src not in sources
            for m in _STATEMENT.finditer(masked):  # ';' only ends statements: strings are masked
                s, e = m.span()
                self._statement(src, masked, s, e, prog, declared, tool_decl, wobj_decl, uses, only_frames)
        for kind, decl, known in (("tool", tool_decl, prog.tools), ("frame", wobj_decl, prog.frames)):
            for name, (pose, ok, why) in decl.items():
                if ok:
                    known[name] = pose
                else:
                    prog.unsupported[f"{kind}:{name}"] = why
        for name in BUILTIN_TOOLS:
            prog.tools.setdefault(name, np.eye(4))
        for name in BUILTIN_WOBJS:
            prog.frames.setdefault(name, np.eye(4))
        prog.tools.update({self.name_key(k): v for k, v in tools.items()})
        prog.frames.update({self.name_key(k): v for k, v in frames.items()})
        named = {n.lower() for src in [*references, *sources]
                 for n in _ANY_ROBTARGET.findall(mask(src.text, [_COMMENT], [_STRING]))}
        self._assign(prog, declared, uses, named)
        return prog

    def _statement(self, src, masked, s, e, prog, declared, tool_decl, wobj_decl, uses, only_frames):
        m = _DECL.search(masked, s, e)
        if m:
            kind, name = m.group(2).lower(), m.group(3)
            if m.group(5) is None or (only_frames and kind == "robtarget"):
                return
            tree, _ = parse_aggregate(src, masked, m.end(), e, f"{kind} {name}")
            where = f"{src.path.name}:{src.line_of(m.start())}"
            if kind == "robtarget":
                declared[name.lower()] = self._robtargets(src, tree, name, m.start(), bool(m.group(4)))
            elif kind == "tooldata":
                tool_decl[name.lower()] = self._tool(src, tree, name, m.start(), where)
            else:
                wobj_decl[name.lower()] = self._wobj(src, tree, name, m.start(), where)
            return
        m = _MOVE.search(masked, s, e)
        if not m or only_frames:
            return
        where_line = m.start()
        target_pos, tool_pos = _MOVES[m.group(1).lower()]
        positional, optional = [], {}
        for ps, pe in split_top(masked, m.end(), e, ","):
            parts = split_top(masked, ps, pe, "\\")
            if masked[parts[0][0]:parts[0][1]].strip():
                positional.append(parts[0])
            for os_, oe in parts[1:]:
                key, _, val = masked[os_:oe].partition(":=")
                optional[key.strip().lower()] = val.strip()
        if len(positional) <= tool_pos:
            raise DataError(f"{src.path.name}:{src.line_of(where_line)}: {m.group(1)} has "
                            f"{len(positional)} arguments, expected at least {tool_pos + 1}")
        tool = masked[slice(*positional[tool_pos])].strip().lower()
        wobj = optional.get("wobj", "wobj0").lower() or "wobj0"
        for k in target_pos:
            a, b = positional[k]
            text = masked[a:b]
            if text.strip().startswith("["):
                tree, _ = parse_aggregate(src, masked, a, b, "robtarget")
                t = self._robtarget(src, tree, f"inline@{src.line_of(a)}", a)
                uses.append(("", t, tool, wobj, a, src))
                continue
            nm = _NAME.match(text) or _FUNC.match(text)
            if nm:
                uses.append((nm.group(1).lower(), None, tool, wobj, a, src))

    def _robtarget(self, src, tree, name, at) -> Target:
        xyz, quat, conf = numbers_of(tree, (3, 4, 4), src, at, f"robtarget {name}")
        config = np.array([float(n.text) for n in conf])
        if not np.all(config == np.round(config)):
            raise DataError(f"{src.path.name}:{src.line_of(at)}: robtarget {name}: confdata must be "
                            f"integers, got {[n.text for n in conf]}")
        cf1, cf4, cf6, cfx = config.astype(int)
        return Target(src, at, name, xyz + quat, config=np.array([cfx, cf1, cf4, cf6]), config_spans=conf)

    def _robtargets(self, src, tree, name, at, array: bool) -> list[Target]:
        if not array:
            return [self._robtarget(src, tree, name, at)]
        out: list[Target] = []

        def walk(node, index):
            is_target = (isinstance(node, list) and node and isinstance(node[0], list)
                         and node[0] and isinstance(node[0][0], Number))
            if is_target:
                out.append(self._robtarget(src, node, f"{name}{{{','.join(map(str, index))}}}",
                                           node[0][0].start))
                return
            if not isinstance(node, list):
                raise DataError(f"{src.path.name}:{src.line_of(at)}: malformed robtarget array {name}")
            for i, child in enumerate(node):
                walk(child, index + [i + 1])

        walk(tree, [])
        return out

    def _tool(self, src, tree, name, at, where):
        if not (isinstance(tree, list) and len(tree) >= 2 and isinstance(tree[0], Word)):
            raise DataError(f"{where}: malformed tooldata {name}: expected [robhold,[[x,y,z],[q]],[load]]")
        vals = [n.value for n in _pose_numbers(tree[1], src, at, f"tooldata {name}")]
        held = tree[0].text.upper() == "TRUE"
        return (self.to_pose(np.array([vals]))[0], held,
                f"{where}: tooldata {name} is a stationary tool (robhold FALSE)")

    def _wobj(self, src, tree, name, at, where):
        if not (isinstance(tree, list) and len(tree) >= 5 and isinstance(tree[0], Word)):
            raise DataError(f"{where}: malformed wobjdata {name}: expected "
                            "[robhold,ufprog,ufmec,[uframe],[oframe]]")
        uf = self.to_pose(np.array([[n.value for n in _pose_numbers(tree[3], src, at, f"wobjdata {name}")]]))
        of = self.to_pose(np.array([[n.value for n in _pose_numbers(tree[4], src, at, f"wobjdata {name}")]]))
        fixed = tree[0].text.upper() == "FALSE" and tree[1].text.upper() == "TRUE"
        return (uf[0] @ of[0], fixed,
                f"{where}: wobjdata {name} is held by the robot or moved by a mechanical unit")

    def _assign(self, prog, declared, uses, named):
        """Give each used robtarget its tool and work object (one per target); a name that no
        robtarget declaration or parameter of these files (``named``) gives is refused."""
        first: dict[str, tuple[str, str, str]] = {}
        order = 0
        for name, inline, tool, wobj, at, src in uses:
            here = f"{src.path.name}:{src.line_of(at)}"
            if inline is not None:
                inline.tool, inline.frame = tool, wobj
                inline.order = order
                order += 1
                prog.targets.append(inline)
                continue
            if name not in declared:
                if name not in named:
                    raise DataError(f"{here}: robtarget {name} is declared nowhere in these files (a typo? "
                                    "give the module that declares it with --references)")
                continue  # a parameter, set at run time (CRobT()), or from a reference module
            if name in first:
                if first[name][:2] != (tool, wobj):
                    raise DataError(
                        f"{here}: robtarget {name} is used with tool {tool} and work object {wobj}, but "
                        f"at {first[name][2]} with {first[name][0]} / {first[name][1]}: one corrected "
                        "target cannot serve both; declare a copy for each use")
                continue
            first[name] = (tool, wobj, here)
            for t in declared[name]:
                t.tool, t.frame, t.order = tool, wobj, order
                order += 1
                prog.targets.append(t)
        for name, targets in declared.items():
            if name not in first:
                prog.warnings.append(f"{targets[0].source.path.name}:{targets[0].line}: robtarget "
                                     f"{targets[0].name.split('{')[0]} is not used by a motion "
                                     "instruction in these files: left as it is")
        prog.targets.sort(key=lambda t: t.order)

