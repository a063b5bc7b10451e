"""The Python API reference (docs/reference/api.md) as a newcomer reads it: every function and class
on the page has a numpydoc docstring with an Examples section, its examples run (doctest), and no
docstring on the page shows a raw Sphinx role (``:func:`` and the like, which the site does not
render)."""

from __future__ import annotations

import doctest
import importlib
import inspect
import re
from pathlib import Path

import pytest

API_PAGE = Path(__file__).resolve().parents[1] / "docs" / "reference" / "api.md"
RAW_ROLE = re.compile(r":(func|class|meth|mod|data|attr|obj|exc|py:\w+):`")
EXAMPLES = re.compile(r"^\s*Examples\n\s*-{8,}\n", re.M)


def page_objects() -> list[tuple[str, object]]:
    out = []
    for target in re.findall(r"^::: (\S+)", API_PAGE.read_text(encoding="utf-8"), re.M):
        module, _, attr = target.rpartition(".")
        try:
            obj = getattr(importlib.import_module(module), attr)
        except (ImportError, AttributeError):
            obj = importlib.import_module(target)
        if inspect.ismodule(obj):
            out += [(f"{target}.{name}", value) for name, value in vars(obj).items()
                    if inspect.isclass(value) and value.__module__ == obj.__name__]
            out.append((target, obj))
        else:
            out.append((target, obj))
    return out


OBJECTS = page_objects()


def docstrings(obj) -> list[tuple[str, str]]:
    """The docstrings of ``obj`` and, for a class, of its public methods and properties."""
    out = [("", inspect.getdoc(obj) or "")]
    if inspect.isclass(obj):
        for name, value in vars(obj).items():
            if not name.startswith("_"):
                doc = getattr(value, "__doc__", None) if not isinstance(value, property) else value.__doc__
                if isinstance(value, (classmethod, staticmethod)):
                    doc = value.__func__.__doc__
                wrapped = isinstance(value, property | classmethod | staticmethod)
                documented = inspect.isfunction(value) or wrapped
                if doc and documented:
                    out.append((name, doc))
    return out


@pytest.mark.parametrize("name, obj", OBJECTS, ids=[n for n, _ in OBJECTS])
def test_documented_with_examples_and_no_raw_roles(name, obj):
    doc = inspect.getdoc(obj) or ""
    if not inspect.ismodule(obj) and not (inspect.isclass(obj) and issubclass(obj, Exception)
                                          and obj.__name__ != "RobocalError"):
        assert EXAMPLES.search(doc), f"{name}: no Examples section"
    for member, text in docstrings(obj):
        raw = RAW_ROLE.search(text)
        assert raw is None, f"{name}{'.' + member if member else ''}: raw role {raw.group(0)!r}"


@pytest.mark.parametrize("name, obj", OBJECTS, ids=[n for n, _ in OBJECTS])
def test_examples_run(name, obj, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # an example that writes a file writes it here
    # a class's examples include its methods' (Robot.fk, Measurements.load...); a module's are its own
    finder = doctest.DocTestFinder(recurse=inspect.isclass(obj))
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    tests = finder.find(obj, name)
    for test in tests:
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} example lines failed"
