"""Constant arithmetic in robot program expressions: ``(-1) * K * 4``, ``nLift + 2.5`` with the
program's named constants, evaluated without ``eval`` (only numbers, names of constants, + - * /,
unary signs and parentheses; anything else is not constant)."""

from __future__ import annotations

import ast
import math
import re

_NAMES = re.compile(r"[A-Za-z_]\w*")
_OPS = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
        ast.Div: lambda a, b: a / b if b else math.nan}


def constant_value(text: str, constants: dict[str, float], fold=str.lower) -> float | None:
    """The value of ``text`` when it is arithmetic on numbers and the names in ``constants``
    (looked up after ``fold``, e.g. lower-casing for RAPID), else None."""
    if len(text) > 200:
        return None
    try:
        tree = ast.parse(text.strip(), mode="eval").body
    except SyntaxError:
        return None

    def value(node) -> float | None:
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            return float(node.value)
        if isinstance(node, ast.Name):
            return constants.get(fold(node.id))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
            v = value(node.operand)
            return None if v is None else (-v if isinstance(node.op, ast.USub) else v)
        if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
            a, b = value(node.left), value(node.right)
            return None if a is None or b is None else _OPS[type(node.op)](a, b)
        return None

    v = value(tree)
    return v if v is not None and math.isfinite(v) else None
