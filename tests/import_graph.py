"""The imports a Python file makes, read from its source: every ``import`` and ``from ... import``
at any level (inside functions too), relative ones resolved. The layer, import-circle,
command-line and suite-convention tests all check this one reading."""

from __future__ import annotations

import ast
from pathlib import Path


def module_name(path: Path, root: Path) -> str:
    """The dotted name of the module at ``path``, a file under ``root`` (the folder holding the top
    package); a package's ``__init__.py`` is the package itself."""
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path, root: Path) -> list[tuple[str, list[str], int]]:
    """(module, names imported from it, line) of every import in the file at ``path`` under ``root``:
    ``import a.b`` gives ``("a.b", [], line)``, ``from .c import d`` the absolute ``c``'s name."""
    name = module_name(path, root)
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            out.append((module, [alias.name for alias in node.names], node.lineno))
        elif isinstance(node, ast.Import):
            out += [(alias.name, [], node.lineno) for alias in node.names]
    return out
