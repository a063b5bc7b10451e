"""The command line is a thin layer over the API (issue 43).

What counts as API: a module of the ``robocal`` package outside ``robocal.cli`` none of whose
dotted parts starts with ``_`` (``robocal.deploy.models``, ``robocal.core.io``), and any public
name it defines (not starting with ``_``; dunder names such as ``__version__`` are public). A
module of ``robocal.cli`` may import such names and the public names of its sibling modules (the
parser helpers of ``robocal.cli.args``), nothing private. Every command's ``run()`` is at most
``MAX_RUN_LINES`` lines (the function's physical lines, docstring and comments included): parse,
one API call, print the result's summary and warnings, write.
"""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import pytest
from import_graph import imports

CLI = Path(__file__).resolve().parents[1] / "src" / "robocal" / "cli"
MAX_RUN_LINES = 60


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


@pytest.mark.parametrize("path", [pytest.param(p, id=p.name) for p in sorted(CLI.glob("*.py"))])
def test_the_command_line_imports_only_public_api(path):
    for module, names, line in imports(path, CLI.parents[1]):
        if module.split(".")[0] != "robocal":
            continue
        where = f"{path.name}:{line}"
        assert not any(_private(part) for part in module.split(".")), f"{where}: private module {module}"
        assert not [n for n in names if _private(n)], f"{where}: private name from {module}: {names}"
        inside = module == "robocal.cli" or module.startswith("robocal.cli.")
        if not inside:
            assert importlib.util.find_spec(module) is not None, f"{where}: {module} is not a robocal module"


@pytest.mark.parametrize("path", [pytest.param(p, id=p.name) for p in sorted(CLI.glob("*.py"))])
def test_every_run_is_short(path):
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.FunctionDef) and node.name == "run":
            lines = node.end_lineno - node.lineno + 1
            assert lines <= MAX_RUN_LINES, f"{path.name}: run() has {lines} lines (at most {MAX_RUN_LINES})"
