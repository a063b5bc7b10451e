"""The Python API reference as a newcomer reads it: a page per public object (scripts/docs_api.py,
every name of ``robocal.__all__`` among them), each a numpydoc docstring with an Examples section
that runs (doctest) and a See Also naming pages of the reference; every public method and function
on a page has its Parameters and Returns sections; no docstring shows a raw Sphinx role
(``:func:`` and the like, which the site does not render)."""

from __future__ import annotations

import doctest
import importlib.util
import inspect
import re
from pathlib import Path

import pytest

import robocal

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("docs_api", ROOT / "scripts" / "docs_api.py")
docs_api = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(docs_api)

RAW_ROLE = re.compile(r":(func|class|meth|mod|data|attr|obj|exc|py:\w+):`")
EXAMPLES = re.compile(r"^\s*Examples\n\s*-{8,}\n", re.M)


def section(doc: str, title: str) -> str | None:
    """The text of numpydoc section ``title`` of ``doc``, None when it has none."""
    following = r"(?=^[A-Z][A-Za-z ]+\n-{3,}\n|\Z)"  # the next section's title, or the end
    match = re.search(rf"^{title}\n-{{{len(title)}}}\n(.*?){following}", doc, re.M | re.S)
    return match.group(1) if match else None


def members(name: str, obj) -> list[tuple[str, object]]:
    """The functions shown on ``name``'s page besides the object: a class's public methods
    (classmethods and staticmethods included), a module page's listed members."""
    if inspect.isclass(obj):
        out = []
        for member, value in vars(obj).items():
            function = value.__func__ if isinstance(value, classmethod | staticmethod) else value
            if not member.startswith("_") and inspect.isfunction(function):
                out.append((f"{name}.{member}", function))
        return out
    if inspect.ismodule(obj):
        listed = docs_api.MODULE_MEMBERS.get(obj.__name__, [])
        if listed is None:
            listed = [m for m, v in vars(obj).items() if not m.startswith("_")
                      and getattr(v, "__module__", None) == obj.__name__]
        return [(f"{name}.{m}", getattr(obj, m)) for m in listed]
    return []


OBJECTS = [(name, docs_api.resolve(name)) for name in docs_api.names()]
FUNCTIONS = [pair for name, obj in OBJECTS for pair in  # and the classes: their constructors
             ([(name, obj)] if inspect.isfunction(obj) or inspect.isclass(obj) else []) + members(name, obj)
             if not (inspect.isclass(pair[1]) and issubclass(pair[1], Exception))]


def test_every_public_name_has_a_page():
    assert set(robocal.__all__) <= {n.removeprefix("rc.") for n in docs_api.names()}
    assert len(set(docs_api.names())) == len(docs_api.names()), "a name on two pages"
    assert docs_api.MAP_MARK in (ROOT / "docs" / docs_api.API_INDEX).read_text(encoding="utf-8")


@pytest.mark.parametrize("name, obj", OBJECTS, ids=[n for n, _ in OBJECTS])
def test_documented_with_examples_see_also_and_no_raw_roles(name, obj):
    doc = inspect.getdoc(obj) or ""
    if not inspect.ismodule(obj) and not (inspect.isclass(obj) and issubclass(obj, Exception)
                                          and obj.__name__ != "RobocalError"):
        assert EXAMPLES.search(doc), f"{name}: no Examples section"
    see_also = section(doc, "See Also")
    assert see_also, f"{name}: no See Also section"
    for line in see_also.splitlines():
        entry = docs_api.SEE_ALSO_ENTRY.match(line)
        if line.strip() and not line.startswith(" "):  # an entry (a description continues indented)
            assert entry, f"{name}: See Also line {line!r} is not 'name : what it is'"
            for target in entry.group(1).split(","):
                assert target.strip() in docs_api._lookup(), f"{name}: See Also {target!r} has no page"
    for member, value in [(name, obj), *members(name, obj)]:
        raw = RAW_ROLE.search(inspect.getdoc(value) or "")
        assert raw is None, f"{member}: raw role {raw.group(0)!r}"


@pytest.mark.parametrize("name, obj", [(n, o) for n, o in OBJECTS if inspect.isclass(o)])
def test_every_public_method_and_property_has_a_docstring(name, obj):
    bare = []
    for member, value in vars(obj).items():
        function = value.__func__ if isinstance(value, classmethod | staticmethod) else value
        shown = isinstance(value, property) or inspect.isfunction(function)
        if not member.startswith("_") and shown and not (function.__doc__ or "").strip():
            bare.append(member)
    assert not bare, f"{name}: {bare} without a docstring"


@pytest.mark.parametrize("name, function", FUNCTIONS, ids=[n for n, _ in FUNCTIONS])
def test_parameters_and_returns_documented(name, function):
    doc = inspect.getdoc(function) or ""
    signature = inspect.signature(function)
    params = [p for p in signature.parameters if p not in ("self", "cls")]
    if params:  # a class may document its constructor's parameters as its Attributes (a dataclass)
        documented = (section(doc, "Parameters") or (inspect.isclass(function) and section(doc, "Attributes"))
                      or "")
        assert documented, f"{name}: no Parameters section"
        names = {n.strip().lstrip("*") for line in documented.splitlines() if line and not line[0].isspace()
                 for n in line.split(" : ")[0].split(",")}
        missing = [p for p in params if p not in names]
        assert not missing, f"{name}: parameters {missing} not in its Parameters section"
    returns = signature.return_annotation not in (inspect.Signature.empty, None, "None")
    if returns and not inspect.isclass(function):
        assert section(doc, "Returns") or section(doc, "Yields"), f"{name}: no Returns section"


@pytest.mark.parametrize("name, obj", OBJECTS, ids=[n for n, _ in OBJECTS])
def test_examples_run(name, obj, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # an example that writes a file writes it here
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    # a class's examples include its methods' and properties' (on its page); a module page's, its members'
    tests = doctest.DocTestFinder(recurse=inspect.isclass(obj)).find(obj, name, globs={})
    for label, value in members(name, obj) if inspect.ismodule(obj) else []:
        tests += doctest.DocTestFinder(recurse=inspect.isclass(value)).find(value, label, globs={})
    for test in tests:
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} example lines failed"


def test_the_nav_holds_the_map_then_a_page_per_object_by_task():
    config = {"nav": [{"Home": "index.md"}, {"Reference": [{"Python API": docs_api.API_INDEX}]}]}
    docs_api.on_config(config)
    section = config["nav"][1]["Reference"][0]["Python API"]
    assert section[0] == {"Module map": docs_api.API_INDEX}
    assert [task for group in section[1:] for task in group] == [task for task, _ in docs_api.GROUPS]
    pages = [(title, uri) for group in section[1:] for items in group.values() for item in items
             for title, uri in item.items()]
    assert pages == [(name, docs_api.page_uri(name)) for name in docs_api.names()]
    page = docs_api.page_markdown("rc.calibrate")
    assert "::: robocal.calibration.pipeline.calibrate" in page and 'heading: "rc.calibrate"' in page


def test_see_also_entries_become_links_to_pages_and_methods():
    from types import SimpleNamespace

    files = SimpleNamespace(get_file_from_path=lambda uri: SimpleNamespace(url=uri.replace(".md", ".html")))
    page = SimpleNamespace(url="reference/api/calibrate.html",
                           file=SimpleNamespace(src_uri="reference/api/calibrate.md"))
    block = "<p>rc.evaluate : Errors on <code>data</code>.\nRobot.fk : Forward\n    kinematics.</p>"
    out = docs_api.see_also_html(block, page, files)
    assert ('<li><a href="evaluate.html"><code>rc.evaluate</code></a>: Errors on <code>data</code>.</li>'
            in out)
    assert ('<a href="Robot.html#robocal.kinematics.model.Robot.fk"><code>Robot.fk</code></a>: Forward '
            "kinematics.</li>") in out
    with pytest.raises(ValueError, match="names no page"):
        docs_api.see_also_html("<p>rc.nowhere : Not a page.</p>", page, files)
