"""An evaluator of the URScript subset robocal's run-time correction uses (tests only): ``def`` /
``while`` / ``if`` / ``elif`` / ``else`` / ``end`` blocks, ``return``, ``[global|local] name =
expr``, numbers, strings, lists, pose literals ``p[...]``, indexing, ``+ - * /``, comparisons,
``and`` / ``or`` / ``not``, calls with keyword arguments; built-ins ``pose_trans``, ``pose_inv``,
``pose_add``, ``sqrt``, ``sin``, ``cos``, ``textmsg``, ``get_tcp_offset``,
``get_actual_joint_positions`` and ``get_inverse_kin`` (the controller, :class:`NominalController`:
the nominal model's closed form, the solution nearest ``qnear``). Rotation vectors are converted
by scipy (not by robocal), so the routine is checked against an independent pose arithmetic.
Every ``def`` of the file is defined (nested ones too); the program's own statements are not run.
"""

from __future__ import annotations

import ast
import math
import re

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.ik import solve_all

_BLOCK = re.compile(r"^(def|while|if|elif)\s+(.*):\s*$|^(else)\s*:\s*$|^(end)\s*$")


class URScriptError(RuntimeError):
    """A run-time error the controller would raise (no IK solution, a name not defined...)."""


class Pose(tuple):
    """A URScript pose: x, y, z (m), rotation vector (rad)."""


def matrix(p) -> np.ndarray:
    """The 4x4 of a pose."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(p[3:6]).as_matrix()
    T[:3, 3] = p[:3]
    return T


def pose(T: np.ndarray) -> Pose:
    return Pose((*T[:3, 3], *Rotation.from_matrix(T[:3, :3]).as_rotvec()))


class _Return(Exception):  # noqa: N818 (control flow, not an error)
    def __init__(self, value):
        self.value = value


class NominalController:
    """The controller's kinematics (base frame = the model's world): ``nominal``'s closed form."""

    def __init__(self, nominal, tcp=None, joints=None):
        self.nominal = nominal
        self.tcp = Pose((0.0,) * 6) if tcp is None else Pose(tcp)
        self.joints = np.zeros(6) if joints is None else np.asarray(joints, float)

    def inverse_kin(self, x: Pose, qnear) -> np.ndarray:
        """Joints (rad) of TCP pose ``x`` with the active TCP, the solution nearest ``qnear``."""
        F = matrix(x) @ np.linalg.inv(matrix(self.tcp))
        cands = solve_all(self.nominal, F[None], extra_turns=True)[0]
        valid = np.isfinite(cands).all(axis=1)
        if not valid.any():
            raise URScriptError("get_inverse_kin: no solution")
        dist = np.where(valid, np.abs(np.where(valid[:, None], cands, 0.0) - np.asarray(qnear)).sum(axis=1),
                        np.inf)
        return cands[int(np.argmin(dist))]


class Evaluator:
    """The defs of URScript ``text``; :meth:`eval` an expression, :meth:`call` a def."""

    def __init__(self, text: str, controller: NominalController):
        self.ctl = controller
        self.defs: dict[str, tuple[list[str], list]] = {}
        self.calls = {"get_inverse_kin": 0}
        self.log: list[str] = []
        lines = [_strip(line) for line in text.splitlines()]
        self._block([ln for ln in lines if ln], 0)

    # --- parsing -------------------------------------------------------------------------------
    def _block(self, lines: list[str], i: int) -> tuple[list, int]:
        """Statements from line ``i`` to the ``end`` / ``elif`` / ``else`` closing the block."""
        out = []
        while i < len(lines):
            m = _BLOCK.match(lines[i])
            if m and (m.group(4) or m.group(3) or m.group(1) == "elif"):
                return out, i
            if m and m.group(1) == "def":
                head = re.match(r"(\w+)\s*\((.*)\)", m.group(2))
                body, i = self._block(lines, i + 1)
                params = [x.strip() for x in head.group(2).split(",") if x.strip()]
                self.defs[head.group(1)] = (params, body)
                i += 1
            elif m and m.group(1) == "while":
                body, i = self._block(lines, i + 1)
                out.append(("while", _expr(m.group(2)), body))
                i += 1
            elif m and m.group(1) == "if":
                branches, rest = [], []
                cond = _expr(m.group(2))
                while True:
                    body, i = self._block(lines, i + 1)
                    branches.append((cond, body))
                    e = _BLOCK.match(lines[i])
                    if e.group(1) == "elif":
                        cond = _expr(e.group(2))
                        continue
                    if e.group(3):
                        rest, i = self._block(lines, i + 1)
                    break
                out.append(("if", branches, rest))
                i += 1
            elif lines[i].startswith("return"):
                out.append(("return", _expr(lines[i][6:]) if lines[i][6:].strip() else None))
                i += 1
            else:
                a = re.match(r"(?:(?:global|local)\s+)?([A-Za-z_]\w*)\s*=(?!=)\s*(.*)$", lines[i])
                out.append(("set", a.group(1), _expr(a.group(2))) if a else ("expr", _expr(lines[i])))
                i += 1
        return out, i

    # --- running -------------------------------------------------------------------------------
    def eval(self, text: str):
        """The value of the URScript expression ``text``."""
        return self._value(_expr(text), {})

    def call(self, name: str, *args):
        params, body = self.defs[name]
        env = dict(zip(params, args, strict=True))
        try:
            self._run(body, env)
        except _Return as r:
            return r.value
        return None

    def _run(self, body: list, env: dict) -> None:
        for st in body:
            if st[0] == "set":
                env[st[1]] = self._value(st[2], env)
            elif st[0] == "expr":
                self._value(st[1], env)
            elif st[0] == "return":
                raise _Return(None if st[1] is None else self._value(st[1], env))
            elif st[0] == "while":
                while self._value(st[1], env):
                    self._run(st[2], env)
            elif st[0] == "if":
                for cond, block in st[1]:
                    if self._value(cond, env):
                        self._run(block, env)
                        break
                else:
                    self._run(st[2], env)

    def _value(self, node, env: dict):
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.Name):
            if node.id in env:
                return env[node.id]
            if node.id in ("True", "False"):
                return node.id == "True"
            raise URScriptError(f"{node.id} is not defined")
        if isinstance(node, ast.List):
            return [self._value(e, env) for e in node.elts]
        if isinstance(node, ast.Subscript):
            if isinstance(node.value, ast.Name) and node.value.id == "p" and "p" not in env:
                items = node.slice.elts if isinstance(node.slice, ast.Tuple) else [node.slice]
                values = [float(self._value(e, env)) for e in items]
                if len(values) != 6:
                    raise URScriptError("a pose has 6 numbers")
                return Pose(values)
            return self._value(node.value, env)[int(self._value(node.slice, env))]
        if isinstance(node, ast.UnaryOp):
            v = self._value(node.operand, env)
            return -v if isinstance(node.op, ast.USub) else (not v if isinstance(node.op, ast.Not) else v)
        if isinstance(node, ast.BinOp):
            x, y = self._value(node.left, env), self._value(node.right, env)
            if isinstance(x, Pose) or isinstance(y, Pose):
                raise URScriptError("no arithmetic on poses: pose_add / pose_trans")
            ops = {ast.Add: lambda: x + y, ast.Sub: lambda: x - y, ast.Mult: lambda: x * y,
                   ast.Div: lambda: x / y}
            return ops[type(node.op)]()
        if isinstance(node, ast.BoolOp):
            values = [self._value(v, env) for v in node.values]  # URScript evaluates both sides
            return all(values) if isinstance(node.op, ast.And) else any(values)
        if isinstance(node, ast.Compare):
            x = self._value(node.left, env)
            ok = True
            for op, right in zip(node.ops, node.comparators, strict=True):
                y = self._value(right, env)
                ok &= {ast.Lt: x < y, ast.LtE: x <= y, ast.Gt: x > y, ast.GtE: x >= y, ast.Eq: x == y,
                       ast.NotEq: x != y}[type(op)]
                x = y
            return ok
        if isinstance(node, ast.Call):
            name = node.func.id
            args = [self._value(a, env) for a in node.args]
            kwargs = {k.arg: self._value(k.value, env) for k in node.keywords}
            if name in self.defs:
                return self.call(name, *args)
            return self._builtin(name, args, kwargs)
        raise URScriptError(f"not in the subset: {ast.dump(node)[:60]}")

    def _builtin(self, name: str, args: list, kwargs: dict):
        if name == "pose_trans":
            return pose(matrix(args[0]) @ matrix(args[1]))
        if name == "pose_inv":
            return pose(np.linalg.inv(matrix(args[0])))
        if name == "pose_add":  # positions added, rotations composed in the base frame
            T = matrix(args[1])[:3, :3] @ matrix(args[0])[:3, :3]
            out = np.eye(4)
            out[:3, :3], out[:3, 3] = T, np.add(args[0][:3], args[1][:3])
            return pose(out)
        if name in ("sqrt", "sin", "cos"):
            return getattr(math, name)(args[0])
        if name == "textmsg":
            self.log.append("".join(str(a) for a in args))
            return None
        if name == "get_tcp_offset":
            return self.ctl.tcp
        if name == "get_actual_joint_positions":
            return list(self.ctl.joints)
        if name == "get_inverse_kin":
            self.calls["get_inverse_kin"] += 1
            qnear = kwargs.get("qnear", args[1] if len(args) > 1 else list(self.ctl.joints))
            return list(self.ctl.inverse_kin(Pose(args[0]), qnear))
        raise URScriptError(f"{name}() is not in the subset")


def _strip(line: str) -> str:
    """A line without its comment (``#`` outside a string) and surrounding blanks."""
    out, quote = [], ""
    for ch in line:
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            break
        out.append(ch)
    return "".join(out).strip()


def _expr(text: str):
    return ast.parse(text.strip(), mode="eval").body
