"""An evaluator of exactly the RAPID subset robocal's run-time correction uses (tests only): module
data declarations (CONST/PERS/VAR of num, bool, string, pos, orient, pose, confdata, robtarget,
jointtarget, tooldata, wobjdata, arrays ``{n}``), LOCAL FUNCs (PROCs are skipped), assignments to
variables, record fields and array elements, FOR, IF/ELSE, RETURN, ErrWrite, + - * / and comparisons,
AND/OR/NOT, aggregates, and the functions PoseMult, PoseInv, PoseVect, OrientZYX, EulerZYX,
VectMagn, Sqrt, Sin, Cos, Abs, Offs, RelTool, CalcJointT, CalcRobT. The controller's kinematics (CalcJointT,
CalcRobT) are a :class:`NominalController`: the nominal model's closed-form IK in the robconf the
robtarget gives (as the controller does). ``single=True`` rounds every num to float32 as the
controller's ``num`` is (a 32-bit float).

Written for the tests from ABB's RAPID reference (Technical reference manual - RAPID Instructions,
Functions and Data types): no ABB code.
"""

from __future__ import annotations

import re

import numpy as np

from robocal.ik import solve_all
from robocal.programs.dialects.rapid.configuration import ABBConfig
from robocal.programs.rotations import matrix_to_quat, quat_to_matrix

SCHEMA = {
    "pos": [("x", "num"), ("y", "num"), ("z", "num")],
    "orient": [("q1", "num"), ("q2", "num"), ("q3", "num"), ("q4", "num")],
    "pose": [("trans", "pos"), ("rot", "orient")],
    "confdata": [("cf1", "num"), ("cf4", "num"), ("cf6", "num"), ("cfx", "num")],
    "extjoint": [(f"eax_{c}", "num") for c in "abcdef"],
    "robjoint": [(f"rax_{i}", "num") for i in range(1, 7)],
    "robtarget": [("trans", "pos"), ("rot", "orient"), ("robconf", "confdata"), ("extax", "extjoint")],
    "jointtarget": [("robax", "robjoint"), ("extax", "extjoint")],
    "loaddata": [("mass", "num"), ("cog", "pos"), ("aom", "orient"), ("ix", "num"), ("iy", "num"),
                 ("iz", "num")],
    "tooldata": [("robhold", "bool"), ("tframe", "pose"), ("tload", "loaddata")],
    "wobjdata": [("robhold", "bool"), ("ufprog", "bool"), ("ufmec", "string"), ("uframe", "pose"),
                 ("oframe", "pose")],
    "progdisp": [("pdisp", "pose"), ("eoffs", "extjoint")],
}
_TOKEN = re.compile(r"\s*(?:(\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)|([A-Za-z_]\w*)|(\"[^\"]*\")|"
                    r"(:=|<=|>=|<>|[\[\](){},;.+\-*/<>=\\:]))")
_COMMENT = re.compile(r"!.*")


class RapidError(Exception):
    """An error the controller would raise (or a construct outside the subset)."""


class Record(dict):
    """A record value: ``type`` and its fields (a dict)."""

    def __init__(self, kind: str, fields: dict):
        super().__init__(fields)
        self.kind = kind


def _tokens(text: str) -> list[str]:
    text = "\n".join(_COMMENT.sub("", line) if '"' not in line else line for line in text.splitlines())
    out, pos = [], 0
    while True:
        m = _TOKEN.match(text, pos)
        if not m:
            if text[pos:].strip():
                raise RapidError(f"cannot read {text[pos:pos + 30]!r}")
            return out
        out.append(next(g for g in m.groups() if g is not None))
        pos = m.end()


class Evaluator:
    """A module's data and functions; :meth:`eval` evaluates an expression in it."""

    def __init__(self, text: str, controller, single: bool = False):
        self.controller, self.single = controller, single
        self.globals: dict[str, object] = {}
        self.types: dict[str, str] = {}
        self.funcs: dict[str, tuple] = {}
        self.toks, self.i = _tokens(text), 0
        self.module_toks = self.toks
        self.log: list[tuple[list, dict]] = []  # ErrWrite calls: (arguments, switches)
        self.calls = {"CalcJointT": 0, "CalcRobT": 0}
        # system data: the active program displacement (none until a test sets one)
        self.globals["c_progdisp"] = self.coerce("progdisp", [[[0, 0, 0], [1, 0, 0, 0]], [9e9] * 6])
        self.types["c_progdisp"] = "progdisp"
        for name, kind, value in (("tool0", "tooldata", [True, [[0, 0, 0], [1, 0, 0, 0]],
                                                         [0.001, [0, 0, 0.001], [1, 0, 0, 0], 0, 0, 0]]),
                                  ("wobj0", "wobjdata", [False, True, "", [[0, 0, 0], [1, 0, 0, 0]],
                                                         [[0, 0, 0], [1, 0, 0, 0]]])):
            self.globals[name], self.types[name] = self.coerce(kind, value), kind  # system data
        self._module()

    # ---------------------------------------------------------------- values
    def num(self, v) -> float:
        return float(np.float32(v)) if self.single else float(v)

    def coerce(self, kind: str, value):
        if kind == "num":
            return self.num(value)
        if kind in ("bool", "string"):
            return value
        fields = SCHEMA[kind]
        if isinstance(value, Record):
            if value.kind != kind:
                raise RapidError(f"a {value.kind} where a {kind} is needed")
            return Record(kind, {f: self.coerce(t, value[f]) for f, t in fields})
        if not isinstance(value, list) or len(value) != len(fields):
            raise RapidError(f"{value!r} is no {kind}")
        return Record(kind, {f: self.coerce(t, v) for (f, t), v in zip(fields, value, strict=True)})

    # ---------------------------------------------------------------- parsing helpers
    def peek(self, k: int = 0) -> str:
        return self.toks[self.i + k] if self.i + k < len(self.toks) else ""

    def take(self, want: str | None = None) -> str:
        t = self.peek()
        if want is not None and t.upper() != want.upper():
            raise RapidError(f"expected {want}, got {t!r} at token {self.i}")
        self.i += 1
        return t

    def is_(self, word: str) -> bool:
        return self.peek().upper() == word.upper()

    def _module(self) -> None:
        while self.i < len(self.toks):
            t = self.peek().upper()
            if t in ("MODULE",):
                self.take()
                self.take()
                if self.is_("("):
                    while not self.is_(")"):
                        self.take()
                    self.take()
            elif t == "ENDMODULE" or t in ("LOCAL", "TASK"):
                self.take()
            elif t in ("CONST", "PERS", "VAR"):
                self._declare(self.globals, self.types, lambda: self._expr(self.globals))
            elif t == "FUNC":
                self._func()
            elif t in ("PROC", "TRAP"):
                end = "END" + t
                while not self.is_(end):
                    self.take()
                self.take()
            else:
                raise RapidError(f"outside the subset at module level: {self.peek()!r}")

    def _declare(self, env: dict, types: dict, value) -> None:
        self.take()
        kind, name = self.take(), self.take()
        size = None
        if self.is_("{"):
            self.take()
            size = int(float(self.take()))
            self.take("}")
        v = None
        if self.is_(":="):
            self.take()
            v = value()
        self.take(";")
        if v is None:
            v = self._default(kind) if size is None else [self._default(kind) for _ in range(size)]
        types[name.lower()] = kind
        if size is not None:
            if len(v) != size:
                raise RapidError(f"{name}{{{size}}} given {len(v)} values")
            env[name.lower()] = [self.coerce(kind, x) for x in v]
        else:
            env[name.lower()] = self.coerce(kind, v)

    def _default(self, kind: str):
        if kind == "num":
            return 0.0
        if kind == "bool":
            return False
        if kind == "string":
            return ""
        return Record(kind, {f: self._default(t) for f, t in SCHEMA[kind]})

    def _func(self) -> None:
        self.take("FUNC")
        kind, name = self.take(), self.take()
        self.take("(")
        params = []
        while not self.is_(")"):
            mode = self.take() if self.peek().upper() in ("PERS", "VAR", "INOUT") else "IN"
            params.append((mode, self.take(), self.take().lower()))
            if self.is_(","):
                self.take()
        self.take(")")
        start = self.i
        depth = 0
        while not (self.is_("ENDFUNC") and depth == 0):
            self.take()
        self.funcs[name.lower()] = (kind, params, start, self.i)
        self.take()

    # ---------------------------------------------------------------- execution
    def call(self, name: str, args: list):
        kind, params, start, end = self.funcs[name.lower()]
        if len(args) != len(params):
            raise RapidError(f"{name} takes {len(params)} arguments")
        env = dict(self.globals)
        types = dict(self.types)
        for (_, t, p), a in zip(params, args, strict=True):
            env[p], types[p] = self.coerce(t, a), t
        saved = self.toks, self.i
        self.toks, self.i = self.module_toks, start
        try:
            result = self._block(env, types, end, ("ENDFUNC",))
        finally:
            self.toks, self.i = saved
        if not isinstance(result, _Return):
            raise RapidError(f"{name} ended without RETURN")
        return self.coerce(kind, result.value)

    def _block(self, env, types, end, stops):
        while self.i < end and self.peek().upper() not in stops:
            r = self._statement(env, types, end)
            if isinstance(r, _Return):
                return r
        return None

    def _skip_block(self, stops) -> str:
        depth = 0
        while True:
            t = self.peek().upper()
            if depth == 0 and t in stops:
                return t
            if t in ("IF", "FOR"):
                depth += 1
            if t in ("ENDIF", "ENDFOR"):
                depth -= 1
            self.take()

    def _statement(self, env, types, end):
        t = self.peek().upper()
        if t in ("CONST", "VAR"):
            self._declare(env, types, lambda: self._expr(env))
            return None
        if t == "RETURN":
            self.take()
            v = self._expr(env)
            self.take(";")
            return _Return(v)
        if t == "FOR":
            self.take()
            var = self.take().lower()
            self.take("FROM")
            lo = self._expr(env)
            self.take("TO")
            hi = self._expr(env)
            self.take("DO")
            body = self.i
            k = lo
            while k <= hi:
                env[var], types[var] = float(k), "num"
                self.i = body
                r = self._block(env, types, end, ("ENDFOR",))
                if isinstance(r, _Return):
                    return r
                k += 1
            self.i = body
            self._skip_block(("ENDFOR",))
            self.take("ENDFOR")
            return None
        if t == "IF":
            self.take()
            cond = self._expr(env)
            self.take("THEN")
            if cond:
                r = self._block(env, types, end, ("ELSE", "ENDIF"))
                if isinstance(r, _Return):
                    return r
                if self.is_("ELSE"):
                    self.take()
                    self._skip_block(("ENDIF",))
            else:
                if self._skip_block(("ELSE", "ENDIF")) == "ELSE":
                    self.take()
                    r = self._block(env, types, end, ("ENDIF",))
                    if isinstance(r, _Return):
                        return r
            self.take("ENDIF")
            return None
        if self.peek(1) in ("\\", ",", ";") or self.peek(1).startswith('"'):  # a procedure call
            return self._procedure(env)
        # an assignment: name [{index}] [.field ...] := expr ;
        name = self.take().lower()
        path: list = []
        while self.peek() in ("{", "."):
            if self.take() == "{":
                path.append(int(self._expr(env)) - 1)
                self.take("}")
            else:
                path.append(self.take().lower())
        self.take(":=")
        value = self._expr(env)
        self.take(";")
        if name not in env:
            raise RapidError(f"{name} is not declared")
        if not path:
            env[name] = self.coerce(types[name], value)
            return None
        holder, kind = env[name], types[name]
        for p in path[:-1]:
            holder = holder[p]
        last = path[-1]
        field_kind = kind if isinstance(last, int) else dict(SCHEMA[holder.kind])[last]
        holder[last] = self.coerce(field_kind, value)
        return None

    def _procedure(self, env):
        """A procedure call statement (ErrWrite only): its arguments, logged in :attr:`log`."""
        name = self.take()
        if name.lower() != "errwrite":
            raise RapidError(f"{name} is outside the subset")
        args, switches = [], {}
        while not self.is_(";"):
            if self.is_("\\"):
                self.take()
                key = self.take().lower()
                switches[key] = True
                if self.is_(":="):
                    self.take()
                    switches[key] = self._expr(env)
            elif self.is_(","):
                self.take()
            else:
                args.append(self._expr(env))
        self.take(";")
        self.log.append((args, switches))
        return None

    # ---------------------------------------------------------------- expressions
    def eval(self, text: str, env: dict | None = None):
        """The value of the expression ``text`` (module data, ``env`` extra names)."""
        saved_toks, saved_i = self.toks, self.i
        self.toks, self.i = _tokens(text), 0
        try:
            v = self._expr({**self.globals, **{k.lower(): w for k, w in (env or {}).items()}})
            if self.i != len(self.toks):
                raise RapidError(f"trailing tokens in {text!r}")
            return v
        finally:
            self.toks, self.i = saved_toks, saved_i

    def _expr(self, env):
        v = self._and(env)
        while self.is_("OR"):
            self.take()
            w = self._and(env)
            v = bool(v) or bool(w)
        return v

    def _and(self, env):
        v = self._cmp(env)
        while self.is_("AND"):
            self.take()
            w = self._cmp(env)
            v = bool(v) and bool(w)
        return v

    def _cmp(self, env):
        v = self._sum(env)
        ops = {"<": np.less, "<=": np.less_equal, ">": np.greater, ">=": np.greater_equal, "=": np.equal,
               "<>": np.not_equal}
        while self.peek() in ops:
            op = self.take()
            v = bool(ops[op](v, self._sum(env)))
        return v

    def _sum(self, env):
        v = self._term(env)
        while self.peek() in ("+", "-"):
            op = self.take()
            w = self._term(env)
            v = self.num(v + w if op == "+" else v - w)
        return v

    def _term(self, env):
        v = self._unary(env)
        while self.peek() in ("*", "/"):
            op = self.take()
            w = self._unary(env)
            v = self.num(v * w if op == "*" else v / w)
        return v

    def _unary(self, env):
        if self.is_("-"):
            self.take()
            return -self._unary(env)
        if self.is_("NOT"):
            self.take()
            return not self._unary(env)
        return self._postfix(env)

    def _postfix(self, env):
        v = self._primary(env)
        while self.peek() in (".", "{"):
            if self.take() == ".":
                v = v[self.take().lower()]
            else:
                v = v[int(self._expr(env)) - 1]
                self.take("}")
        return v

    def _primary(self, env):
        t = self.take()
        if t == "(":
            v = self._expr(env)
            self.take(")")
            return v
        if t == "[":
            items = []
            while not self.is_("]"):
                items.append(self._expr(env))
                if self.is_(","):
                    self.take()
            self.take("]")
            return items
        if t[0].isdigit() or t[0] == ".":
            return self.num(float(t))
        if t.startswith('"'):
            return t[1:-1]
        if t.upper() in ("TRUE", "FALSE"):
            return t.upper() == "TRUE"
        if self.is_("("):
            self.take()
            args, named = [], {}
            while not self.is_(")"):
                if self.is_("\\"):
                    self.take()
                    key = self.take().lower()
                    named[key] = True
                    if self.is_(":="):
                        self.take()
                        named[key] = self._expr(env)
                else:
                    args.append(self._expr(env))
                if self.is_(","):
                    self.take()
            self.take(")")
            return self._call(t, args, named)
        if t.lower() not in env:
            raise RapidError(f"{t} is not declared")
        return env[t.lower()]

    def _call(self, name: str, args: list, named: dict):
        low = name.lower()
        if low in self.funcs:
            return self.call(name, args)
        builtin = getattr(self, "_f_" + low, None)
        if builtin is None:
            raise RapidError(f"{name} is outside the subset")
        return builtin(*args, **named)

    # ---------------------------------------------------------------- pose arithmetic
    def matrix(self, pose) -> np.ndarray:
        """4x4 (mm) of a pose-like record (pose, or trans/rot of a robtarget)."""
        T = np.eye(4)
        q = np.array([pose["rot"][k] for k in ("q1", "q2", "q3", "q4")])
        T[:3, :3] = quat_to_matrix(q[None])[0]
        T[:3, 3] = [pose["trans"][k] for k in "xyz"]
        return T

    def pose(self, T: np.ndarray, old=None) -> Record:
        q = matrix_to_quat(T[None, :3, :3], np.array([[1.0, 0, 0, 0]] if old is None else [old]))[0]
        return self.coerce("pose", [list(T[:3, 3]), list(q)])

    def _f_posemult(self, a, b):
        return self.pose(self.matrix(a) @ self.matrix(b))

    def _f_poseinv(self, a):
        return self.pose(np.linalg.inv(self.matrix(a)))

    def _f_posevect(self, a, p):
        return self.coerce("pos", list(self.matrix(a) @ np.array([p["x"], p["y"], p["z"], 1.0]))[:3])

    def _f_orientzyx(self, z, y, x):
        R = quat_to_matrix(np.array([[1.0, 0, 0, 0]]))[0]
        for axis, deg in (("z", z), ("y", y), ("x", x)):
            c, s = np.cos(np.deg2rad(deg)), np.sin(np.deg2rad(deg))
            m = {"z": [[c, -s, 0], [s, c, 0], [0, 0, 1]], "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],
                 "x": [[1, 0, 0], [0, c, -s], [0, s, c]]}[axis]
            R = R @ np.array(m)
        return self.coerce("orient", list(matrix_to_quat(R[None], np.array([[1.0, 0, 0, 0]]))[0]))

    def _f_eulerzyx(self, rot, x=False, y=False, z=False):
        R = quat_to_matrix(np.array([[rot[k] for k in ("q1", "q2", "q3", "q4")]]))[0]
        angles = {"z": np.arctan2(R[1, 0], R[0, 0]), "y": np.arcsin(-np.clip(R[2, 0], -1, 1)),
                  "x": np.arctan2(R[2, 1], R[2, 2])}
        which = "x" if x else "y" if y else "z"
        return self.num(np.rad2deg(angles[which]))

    def _f_vectmagn(self, p):
        return self.num(np.sqrt(p["x"] ** 2 + p["y"] ** 2 + p["z"] ** 2))

    def _f_sqrt(self, v):
        return self.num(np.sqrt(v))

    def _f_sin(self, deg):
        return self.num(np.sin(np.deg2rad(deg)))

    def _f_cos(self, deg):
        return self.num(np.cos(np.deg2rad(deg)))

    def _f_abs(self, v):
        return self.num(abs(v))

    def _f_offs(self, p, x, y, z):
        out = self.coerce("robtarget", p)
        for k, d in zip("xyz", (x, y, z), strict=True):
            out["trans"][k] = self.num(out["trans"][k] + d)
        return out

    def _f_reltool(self, p, x, y, z, rx=0.0, ry=0.0, rz=0.0):
        out = self.coerce("robtarget", p)
        T = self.matrix(p) @ self.matrix(self.coerce("pose", [[x, y, z], [1, 0, 0, 0]]))
        T[:3, :3] = T[:3, :3] @ self.matrix({"trans": {"x": 0, "y": 0, "z": 0},
                                              "rot": self._f_orientzyx(rz, ry, rx)})[:3, :3]
        new = self.pose(T, [p["rot"][k] for k in ("q1", "q2", "q3", "q4")])
        out["trans"], out["rot"] = new["trans"], new["rot"]
        return out

    def _f_calcjointt(self, target, tool, wobj=None, **_):
        self.calls["CalcJointT"] += 1
        q = self.controller.calc_joint_t(self, target, tool, wobj)
        return self.coerce("jointtarget", [list(np.rad2deg(q)), [9e9] * 6])

    def _f_calcrobt(self, joints, tool, wobj=None, **_):
        self.calls["CalcRobT"] += 1
        return self.controller.calc_rob_t(self, joints, tool, wobj)


class _Return:
    def __init__(self, value):
        self.value = value


class NominalController:
    """The controller's kinematics: ``nominal`` (a Robot with a closed form), world = its world."""

    def __init__(self, nominal):
        self.nominal, self.scheme = nominal, ABBConfig()

    def world(self, ev: Evaluator, wobj) -> np.ndarray:
        """The frame a robtarget is in: uframe * oframe * the active program displacement (mm)."""
        frame = np.eye(4) if wobj is None else ev.matrix(wobj["uframe"]) @ ev.matrix(wobj["oframe"])
        return frame @ ev.matrix(ev.globals["c_progdisp"]["pdisp"])

    def calc_joint_t(self, ev: Evaluator, target, tool, wobj) -> np.ndarray:
        """Joints (rad) of ``target`` in its robconf (ERR_ROBLIMIT: RapidError)."""
        X = self.world(ev, wobj) @ ev.matrix(target) @ np.linalg.inv(ev.matrix(tool["tframe"]))
        X[:3, 3] *= 1e-3
        cands = solve_all(self.nominal, X[None], extra_turns=True)[0]
        valid = np.isfinite(cands).all(axis=1)
        if not valid.any():
            raise RapidError("ERR_ROBLIMIT: out of reach")
        c = target["robconf"]
        want = np.array([int(c["cfx"]), int(c["cf1"]), int(c["cf4"]), int(c["cf6"])])
        score = np.where(valid, self.scheme.score(self.scheme.encode(self.nominal, np.where(
            valid[:, None], cands, 0.0)), want[None]), np.iinfo(np.int64).max)
        return cands[int(np.argmin(score))]

    def calc_rob_t(self, ev: Evaluator, joints, tool, wobj):
        q = np.deg2rad([joints["robax"][f"rax_{i}"] for i in range(1, 7)])
        F = self.nominal.fk(q[None])[0]
        F[:3, 3] *= 1e3
        T = np.linalg.inv(self.world(ev, wobj)) @ F @ ev.matrix(tool["tframe"])
        conf = self.scheme.encode(self.nominal, q[None])[0]
        p = ev.pose(T)
        return ev.coerce("robtarget", [p["trans"], p["rot"], [conf[1], conf[2], conf[3], conf[0]], [9e9] * 6])
