"""The test suite's own conventions (issue 43): helpers are imported from plain modules, never from
conftest; test files are named by what they test, not by the round that added them."""

from __future__ import annotations

import ast
import re
from pathlib import Path

from import_graph import imports

TESTS = Path(__file__).resolve().parent


def test_no_test_imports_conftest():
    """conftest holds fixtures and hooks only; shared helpers live in robots.py, children.py, ..."""
    offenders = []
    for path in sorted(TESTS.glob("*.py")):
        offenders += [f"{path.name}:{line}" for module, _, line in imports(path, TESTS)
                      if module.split(".")[-1] == "conftest"]
    assert not offenders, offenders


def test_test_files_are_not_named_by_a_round():
    """test_workflow_mistakes_3.py said when it was written, not what it tests."""
    numbered = [p.name for p in TESTS.glob("test_*.py") if re.search(r"_(\d+|round\w*)\.py$", p.name)]
    assert not numbered, numbered


def _calls(path: Path):
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            yield node


def test_every_wait_on_a_child_process_has_a_deadline():
    """subprocess.run(..., timeout=...); a Popen child's output and exit are awaited through
    children.py (read_line, wait, communicate: each kills a child that stops answering)."""
    offenders = []
    for path in sorted(TESTS.glob("*.py")):
        if path.name == "children.py":
            continue
        for call in _calls(path):
            keywords = {k.arg for k in call.keywords}
            name, owner = call.func.attr, ast.unparse(call.func.value)
            if (name == "run" and owner == "subprocess" and "timeout" not in keywords
                    or name in ("wait", "communicate") and not call.args and "timeout" not in keywords
                    or name == "readline" and owner.endswith(".stdout")):
                offenders.append(f"{path.name}:{call.lineno}: {ast.unparse(call)[:60]}")
    assert not offenders, offenders
