"""The package's layers (docs/explanation/architecture.md): each sub-package imports only from the
layers below it, function-level imports included, the package root holds at most three loose
modules, and no module is named like its own function."""

from __future__ import annotations

import ast
from pathlib import Path

from import_graph import imports

import robocal

PACKAGE = Path(robocal.__file__).parent

# bottom to top; a package may import from the layers before its own, never from its own layer's
# other packages or from above
LAYERS = [
    ["core"],
    ["kinematics"],
    ["data", "ik"],
    ["identify"],
    ["trust", "report"],
    ["calibration"],
    ["deploy"],
    ["programs"],
    ["campaign", "history"],
    ["demo"],
    ["cli"],
]
LEVEL = {name: k for k, layer in enumerate(LAYERS) for name in layer}


def _imported_packages(path: Path) -> set[str]:
    """The robocal sub-packages (first name under robocal) a module imports, at any level."""
    modules = [module for module, _, _ in imports(path, PACKAGE.parent)]
    return {module.split(".")[1] for module in modules if module.startswith("robocal.")}


def test_every_sub_package_has_a_layer():
    packages = {p.name for p in PACKAGE.iterdir() if p.is_dir() and any(p.glob("*.py"))}
    modules = {p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__"}
    assert packages | modules == set(LEVEL), "add the new package to LAYERS (and to architecture.md)"


def test_imports_go_only_downward():
    upward = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        if rel.name == "__init__.py" and len(rel.parts) == 1:
            continue  # the package root re-exports the API lazily, from every layer
        own = rel.parts[0].removesuffix(".py")
        for other in _imported_packages(path) - {own}:
            if LEVEL[other] >= LEVEL[own]:
                upward.append(f"{rel} imports robocal.{other} (layer {LEVEL[other]} >= {LEVEL[own]})")
    assert not upward, "\n".join(upward)


def test_the_report_renders_the_result_json_alone():
    """The report reads only the documented result JSON: it imports nothing of robocal but core."""
    imported = set().union(*(_imported_packages(p) for p in (PACKAGE / "report").rglob("*.py")))
    assert imported <= {"core", "report"}, sorted(imported)


def test_the_root_shows_the_layers():
    loose = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(loose) <= 3, loose


def test_no_module_is_named_like_its_own_function():
    # `from robocal.x.y import y` would be ambiguous, and such a name once forced a module-object hack
    # in the package root
    named_alike = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tops = ast.parse(path.read_text()).body
        defined = {node.name for node in tops
                   if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))}
        if path.stem in defined:
            named_alike.append(str(path.relative_to(PACKAGE)))
    assert not named_alike, f"rename the function or the module: {named_alike}"


def test_the_architecture_picture_shows_these_layers():
    """docs/explanation/architecture.svg is drawn from the same layers (scripts/docs_architecture_svg.py)."""
    import importlib.util

    script = Path(__file__).resolve().parents[1] / "scripts" / "docs_architecture_svg.py"
    spec = importlib.util.spec_from_file_location("docs_architecture_svg", script)
    drawing = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(drawing)
    assert [packages for packages, _ in drawing.LAYERS] == LAYERS
    svg = script.parents[1] / "docs" / "explanation" / "architecture.svg"
    assert svg.read_text() == drawing.drawing(), "run scripts/docs_architecture_svg.py"
