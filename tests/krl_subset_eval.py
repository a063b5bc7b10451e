"""An evaluator of the KUKA KRL subset robocal's run-time correction uses
(:mod:`robocal.programs.dialects.krl.runtime`), written from the KRL semantics, not from the
writer: it runs the generated ``DEFFCT`` functions the way a controller would.

Subset: ``DEFFCT type name(p:IN, ...)`` ... ``ENDFCT`` (``DEF`` ... ``END`` skipped), ``DECL``
(INT, REAL, BOOL, FRAME, POS, E6POS, AXIS, E6AXIS, arrays ``name[n]``), assignment to variables,
fields and elements, ``FOR v = a TO b [STEP s]`` / ``ENDFOR``, ``IF cond THEN`` / ``ELSE`` /
``ENDIF``, ``RETURN``; expressions with + - * /, comparisons (== <> < > <= >=), the geometric
operator ``:`` (binds tightest; the result has the right operand's type, its S/T/E kept), flat
aggregates ``{X 1, ...}``, the built-ins SIN, COS, TAN, ATAN2, SQRT, ABS (degrees), INV_POS,
INVERSE(pos, start_axis, err) and FORWARD(axis, err) (``err`` an OUT variable). A ``.dat``:
``DECL type name[=value]`` and ``name[i]=value``. REAL values are stored as 32-bit floats (as
KRL's REAL); frame arithmetic is done in double and stored back into REAL fields.

``INVERSE`` and ``FORWARD`` are the controller's nominal model: given as callables (the tests
use the nominal model's closed-form IK honouring S and T).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

FIELDS = {
    "FRAME": ("X", "Y", "Z", "A", "B", "C"),
    "POS": ("X", "Y", "Z", "A", "B", "C", "S", "T"),
    "E6POS": ("X", "Y", "Z", "A", "B", "C", "S", "T", "E1", "E2", "E3", "E4", "E5", "E6"),
    "AXIS": ("A1", "A2", "A3", "A4", "A5", "A6"),
    "E6AXIS": ("A1", "A2", "A3", "A4", "A5", "A6", "E1", "E2", "E3", "E4", "E5", "E6"),
}
INT_FIELDS = {"S", "T"}
_TOKEN = re.compile(r"\s*(?:(?P<num>(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?)|(?P<name>\$?[A-Za-z_]\w*)|"
                    r"(?P<op><>|==|<=|>=|[-+*/:=(),\[\]{}.<>]))")


class KRLError(Exception):
    """The text is outside the subset, or a run-time error of the program."""


@dataclass
class Struct:
    type: str
    values: dict = field(default_factory=dict)

    def copy(self) -> Struct:
        return Struct(self.type, dict(self.values))


def real(x: float) -> float:
    """A value stored in a KRL REAL (32-bit)."""
    return float(np.float32(x))


def to_matrix(s: Struct) -> np.ndarray:
    """A FRAME/POS/E6POS -> 4x4 (mm)."""
    v = s.values
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("ZYX", [v["A"], v["B"], v["C"]], degrees=True).as_matrix()
    T[:3, 3] = [v["X"], v["Y"], v["Z"]]
    return T


def from_matrix(T: np.ndarray, like: Struct) -> Struct:
    """4x4 (mm) -> ``like``'s type with X..C from ``T`` and its other fields kept."""
    out = like.copy()
    R = T[:3, :3]
    b = math.degrees(math.asin(max(-1.0, min(1.0, -R[2, 0]))))
    if abs(R[2, 0]) < 1 - 1e-12:
        a = math.degrees(math.atan2(R[1, 0], R[0, 0]))
        c = math.degrees(math.atan2(R[2, 1], R[2, 2]))
    else:  # gimbal lock: C = 0
        a, c = math.degrees(math.atan2(-R[0, 1], R[1, 1])), 0.0
    for k, val in zip(("X", "Y", "Z", "A", "B", "C"), (*T[:3, 3], a, b, c), strict=True):
        out.values[k] = real(val)
    return out


def tokens(text: str) -> list[str]:
    out, at = [], 0
    text = text.rstrip()
    while at < len(text):
        m = _TOKEN.match(text, at)
        if not m or m.end() == at:
            raise KRLError(f"cannot read {text[at:]!r}")
        out.append(m.group(m.lastgroup))
        at = m.end()
    return out


class Machine:
    """The controller: module data, functions, system variables, INVERSE/FORWARD."""

    def __init__(self, inverse: Callable, forward: Callable, system: dict | None = None):
        self.inverse, self.forward = inverse, forward
        null = Struct("FRAME", dict.fromkeys(FIELDS["FRAME"], 0.0))
        self.globals: dict = {"$NULLFRAME": null, "$BASE": null.copy(), "$TOOL": null.copy(),
                              "$ROBROOT": null.copy(), **(system or {})}
        self.types: dict = {}
        self.functions: dict = {}
        self.calls: dict[str, int] = {}  # built-in name / ':' / 'statements' -> times called or run

    # ------------------------------------------------------------------ loading
    def load_dat(self, text: str) -> None:
        for line in _lines(text):
            head = line.split()[0].upper()
            if head in ("DEFDAT", "ENDDAT"):
                continue
            m = re.match(r"(?:DECL\s+)?(?:GLOBAL\s+)?(?:CONST\s+)?"
                         r"(INT|REAL|BOOL|FRAME|POS|E6POS|AXIS|E6AXIS)\s+"
                         r"(\w+)\s*(?:\[\s*(\d+)\s*\])?\s*(?:=\s*(.+))?$", line, re.IGNORECASE)
            if m:
                self._declare(self.globals, self.types, m.group(1).upper(), m.group(2).upper(), m.group(3))
                if m.group(4):
                    self._assign(m.group(2).upper(), [], self._eval(tokens(m.group(4)), {}, {}), {}, {})
                continue
            m = re.match(r"(\w+)\s*\[\s*(\d+)\s*\]\s*=\s*(.+)$", line)
            if not m:
                raise KRLError(f"data line outside the subset: {line!r}")
            self._assign(m.group(1).upper(), [("index", int(m.group(2)))],
                         self._eval(tokens(m.group(3)), {}, {}), {}, {})

    def load_src(self, text: str) -> None:
        """The DEFFCT functions of a module (DEF routines are skipped)."""
        lines = _lines(text)
        k = 0
        while k < len(lines):
            m = re.match(r"(?:GLOBAL\s+)?DEFFCT\s+(\w+)\s+(\w+)\s*\(([^)]*)\)", lines[k], re.IGNORECASE)
            if not m:
                k += 1
                continue
            end = next(j for j in range(k, len(lines)) if lines[j].upper() == "ENDFCT")
            params = [p.split(":")[0].strip().upper() for p in m.group(3).split(",") if p.strip()]
            body, decls = _block(lines[k + 1:end]), []
            self.functions[m.group(2).upper()] = (m.group(1).upper(), params, body, decls)
            k = end + 1

    # ------------------------------------------------------------------ running
    def call(self, name: str, args: list):
        rtype, params, body, _ = self.functions[name.upper()]
        local, types = {}, {}
        for stmt in body:
            if stmt[0] == "decl":
                for n, dim in stmt[2]:
                    self._declare(local, types, stmt[1], n, dim)
        if len(args) != len(params):
            raise KRLError(f"{name} takes {len(params)} arguments")
        for p, a in zip(params, args, strict=True):
            local[p] = self._convert(a, types.get(p))
        try:
            self._run([s for s in body if s[0] != "decl"], local, types)
        except _Return as r:
            return self._convert(r.value, rtype)
        raise KRLError(f"{name} ended without RETURN")

    def evaluate(self, text: str):
        """An expression of the program (a motion's target) in the module's data."""
        return self._eval(tokens(text), {}, {})

    def _run(self, body, local, types):
        for stmt in body:
            kind = stmt[0]
            self.calls["statements"] = self.calls.get("statements", 0) + 1
            if kind == "assign":
                target, path = _lvalue(stmt[1], self, local, types)
                self._assign(target, path, self._eval(stmt[2], local, types), local, types)
            elif kind == "for":
                var, lo, hi = stmt[1], self._eval(stmt[2], local, types), self._eval(stmt[3], local, types)
                i = int(lo)
                while i <= int(hi):
                    self._scope(var, local)[var] = i
                    self._run(stmt[4], local, types)
                    i += 1
            elif kind == "if":
                self._run(stmt[2] if self._eval(stmt[1], local, types) else stmt[3], local, types)
            elif kind == "return":
                raise _Return(self._eval(stmt[1], local, types))
            else:
                raise KRLError(f"statement outside the subset: {stmt}")

    def _scope(self, name, local):
        if name in local:
            return local
        if name in self.globals:
            return self.globals
        raise KRLError(f"{name} is not declared")

    def _declare(self, scope, types, t, name, dim):
        types[name] = t
        scope[name] = {} if dim else _default(t)
        if dim:
            types[name + "[]"] = t
            for i in range(1, int(dim) + 1):
                scope[name][i] = _default(t)

    def _convert(self, value, t):
        if t is None:
            return value
        if t in FIELDS:
            if not isinstance(value, Struct):
                raise KRLError(f"a {t} cannot take {value!r}")
            out = _default(t)
            for k in FIELDS[t]:
                if k in value.values:
                    out.values[k] = value.values[k]
            return out
        if t == "INT":
            return int(value)
        if t == "REAL":
            return real(value)
        return value

    def _assign(self, name, path, value, local, types):
        scope = self._scope(name, local)
        t = (types if scope is local else self.types).get(name)
        if not path:
            scope[name] = self._convert(value, t)
            return
        holder, key = scope, name
        for _, k in path:
            holder = holder[key]
            key = k
        if isinstance(holder, Struct):
            holder.values[key] = int(value) if key in INT_FIELDS else real(value)
        else:
            holder[key] = self._convert(value, (types if scope is local else self.types).get(name + "[]"))

    # ------------------------------------------------------------------ expressions
    def _eval(self, toks, local, types):
        p = _Parser(toks, self, local, types)
        value = p.comparison()
        if p.k != len(toks):
            raise KRLError(f"unexpected {toks[p.k]!r} in {' '.join(toks)}")
        return value

    def builtin(self, name, args, arg_tokens, local, types):
        self.calls[name] = self.calls.get(name, 0) + 1
        deg = math.radians
        simple = {"SIN": lambda x: math.sin(deg(x)), "COS": lambda x: math.cos(deg(x)),
                  "TAN": lambda x: math.tan(deg(x)), "SQRT": math.sqrt, "ABS": abs,
                  "ATAN2": lambda y, x: math.degrees(math.atan2(y, x))}
        if name in simple:
            return simple[name](*args)
        if name == "INV_POS":
            return from_matrix(np.linalg.inv(to_matrix(args[0])), args[0])
        if name in ("INVERSE", "FORWARD"):
            out_name, out_path = _lvalue(arg_tokens[-1], self, local, types)
            if name == "INVERSE":
                joints, err = self.inverse(self, args[0], args[1])
                result = _default("E6AXIS")
                for k in range(6):
                    result.values[f"A{k + 1}"] = real(joints[k]) if err == 0 else 0.0
                for k in range(1, 7):
                    result.values[f"E{k}"] = args[0].values.get(f"E{k}", 0.0)
            else:
                result, err = self.forward(self, args[0])
            self._assign(out_name, out_path, err, local, types)
            return result
        raise KRLError(f"function {name} is outside the subset")


class _Return(Exception):  # noqa: N818 - control flow, not an error
    def __init__(self, value):
        self.value = value


def _default(t: str):
    if t in FIELDS:
        return Struct(t, {k: (0 if k in INT_FIELDS else 0.0) for k in FIELDS[t]})
    return {"INT": 0, "REAL": 0.0, "BOOL": False}[t]


def _lines(text: str) -> list[str]:
    """Code lines without comments, blank lines and surrounding space."""
    out = []
    for line in re.split(r"\r\n|\r|\n", text):
        line = re.sub(r'"[^"]*"', '""', line).split(";")[0].strip()
        if line:
            out.append(line)
    return out


def _block(lines: list[str]) -> list:
    """Lines -> statements (nested FOR / IF bodies)."""
    out, k = [], 0
    while k < len(lines):
        stmt, k = _statement(lines, k)
        out.append(stmt)
    return out


def _until(lines, k, words):
    """Statements from line k to the first line (at this depth) starting with one of ``words``."""
    body = []
    while k < len(lines) and lines[k].split()[0].upper() not in words:
        stmt, k = _statement(lines, k)
        body.append(stmt)
    if k == len(lines):
        raise KRLError(f"missing {words}")
    return body, k


def _statement(lines, k):
    line = lines[k]
    head = line.split()[0].upper()
    if head == "DECL":
        m = re.match(r"DECL\s+(\w+)\s+(.+)$", line, re.IGNORECASE)
        names = [(n.upper(), d) for n, d in re.findall(r"(\w+)\s*(?:\[\s*(\d+)\s*\])?", m.group(2))]
        return ("decl", m.group(1).upper(), names), k + 1
    if head == "FOR":
        m = re.match(r"FOR\s+(\w+)\s*=\s*(.+?)\s+TO\s+(.+)$", line, re.IGNORECASE)
        if not m or re.search(r"\bSTEP\b", m.group(3), re.IGNORECASE):
            raise KRLError(f"FOR outside the subset: {line!r}")
        body, k = _until(lines, k + 1, ("ENDFOR",))
        return ("for", m.group(1).upper(), tokens(m.group(2)), tokens(m.group(3)), body), k + 1
    if head == "IF":
        m = re.match(r"IF\s+(.+)\s+THEN$", line, re.IGNORECASE)
        then, k = _until(lines, k + 1, ("ELSE", "ENDIF"))
        other = []
        if lines[k].upper() == "ELSE":
            other, k = _until(lines, k + 1, ("ENDIF",))
        return ("if", tokens(m.group(1)), then, other), k + 1
    if head == "RETURN":
        return ("return", tokens(line[len("RETURN"):])), k + 1
    toks = tokens(line)
    eq = toks.index("=") if "=" in toks else -1
    if eq < 1:
        raise KRLError(f"statement outside the subset: {line!r}")
    return ("assign", toks[:eq], toks[eq + 1:]), k + 1


def _lvalue(toks, machine, local, types):
    """(variable name, path of ('field', F) / ('index', i)) of an assignment's left side."""
    name, path, k = toks[0].upper(), [], 1
    while k < len(toks):
        if toks[k] == ".":
            path.append(("field", toks[k + 1].upper()))
            k += 2
        elif toks[k] == "[":
            j = _closing(toks, k, "[", "]")
            path.append(("index", int(machine._eval(toks[k + 1:j], local, types))))
            k = j + 1
        else:
            raise KRLError(f"cannot assign to {' '.join(toks)}")
    return name, path


def _closing(toks, k, open_, close):
    depth = 0
    for j in range(k, len(toks)):
        depth += toks[j] == open_
        depth -= toks[j] == close
        if depth == 0:
            return j
    raise KRLError(f"unbalanced {open_}")


class _Parser:
    def __init__(self, toks, machine, local, types):
        self.t, self.k, self.m, self.local, self.types = toks, 0, machine, local, types

    def peek(self):
        return self.t[self.k] if self.k < len(self.t) else None

    def take(self):
        self.k += 1
        return self.t[self.k - 1]

    def comparison(self):
        left = self.additive()
        ops = {"==": lambda a, b: a == b, "<>": lambda a, b: a != b, "<": lambda a, b: a < b,
               ">": lambda a, b: a > b, "<=": lambda a, b: a <= b, ">=": lambda a, b: a >= b}
        while self.peek() in ops:
            op = ops[self.take()]
            left = op(left, self.additive())
        return left

    def additive(self):
        left = self.term()
        while self.peek() in ("+", "-"):
            op = self.take()
            right = self.term()
            left = left + right if op == "+" else left - right
        return left

    def term(self):
        left = self.unary()
        while self.peek() in ("*", "/"):
            op = self.take()
            right = self.unary()
            if op == "*":
                left = left * right
            elif isinstance(left, int) and isinstance(right, int):
                left = int(left / right)
            else:
                left = left / right
        return left

    def unary(self):
        if self.peek() in ("-", "+"):
            sign = -1 if self.take() == "-" else 1
            return sign * self.unary()
        return self.geometric()

    def geometric(self):
        left = self.postfix()
        while self.peek() == ":":
            self.take()
            right = self.postfix()
            if not (isinstance(left, Struct) and isinstance(right, Struct)):
                raise KRLError("the ':' operator takes frames and positions")
            left = from_matrix(to_matrix(left) @ to_matrix(right), right)
            self.m.calls[":"] = self.m.calls.get(":", 0) + 1
        return left

    def postfix(self):
        value, name = self.primary()
        while self.peek() in (".", "["):
            if self.take() == ".":
                value = value.values[self.take().upper()]
            else:
                j = _closing(self.t, self.k - 1, "[", "]")
                index = int(self.m._eval(self.t[self.k:j], self.local, self.types))
                self.k = j + 1
                value = value[index]
        return value

    def primary(self):
        tok = self.take()
        if tok == "(":
            value = self.comparison()
            if self.take() != ")":
                raise KRLError("missing )")
            return value, None
        if tok == "{":
            return self.aggregate(), None
        if re.fullmatch(r"[\d.]", tok[0]):
            return (float(tok) if re.search(r"[.eE]", tok) else int(tok)), None
        name = tok.upper()
        if self.peek() == "(":
            j = _closing(self.t, self.k, "(", ")")
            pieces, depth, start = [], 0, self.k + 1
            for i in range(self.k + 1, j):
                depth += self.t[i] in "([{"
                depth -= self.t[i] in ")]}"
                if self.t[i] == "," and depth == 0:
                    pieces.append(self.t[start:i])
                    start = i + 1
            if j > self.k + 1:
                pieces.append(self.t[start:j])
            self.k = j + 1
            out_arg = {"INVERSE": 2, "FORWARD": 1}.get(name)
            args = [None if i == out_arg else self.m._eval(p, self.local, self.types)
                    for i, p in enumerate(pieces)]
            if name in self.m.functions:
                return self.m.call(name, args), None
            return self.m.builtin(name, args, pieces, self.local, self.types), None
        scope = self.local if name in self.local else self.m.globals
        if name not in scope:
            raise KRLError(f"{name} is not declared")
        value = scope[name]
        return (value.copy() if isinstance(value, Struct) else value), name

    def aggregate(self):
        values, t = {}, None
        while self.peek() != "}":
            key = self.take().upper()
            if self.peek() == ":":  # {E6POS: X 1, ...}
                self.take()
                t = key
                continue
            sign = 1
            while self.peek() in ("-", "+"):
                sign *= -1 if self.take() == "-" else 1
            values[key] = sign * float(self.take())
            if self.peek() == ",":
                self.take()
        self.take()
        if t is None:
            t = next(n for n in ("FRAME", "E6POS", "E6AXIS") if set(values) <= set(FIELDS[n]))
        out = _default(t)
        out.values.update({k: (int(v) if k in INT_FIELDS else real(v)) for k, v in values.items()})
        return out
