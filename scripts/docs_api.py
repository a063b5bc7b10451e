"""MkDocs hook: the Python API reference, one page per public object, generated when the site is built.

``GROUPS`` below is the one list of what the reference shows, grouped by task: every name of
``robocal.__all__`` (tests/test_api_docs.py checks that none is missing) and the public objects
users import from a subpackage (``robocal.history.History``). Each name gets a page titled by the
name users write (``rc.calibrate``, not ``robocal.calibration.pipeline.calibrate``) that renders its
docstring with mkdocstrings, a class's public methods on its page; ``docs/reference/api.md`` is the
module map (each object, one line, by task), and keeps the anchors of the old one-page reference
(``api.md#robocal.data.measurements.Measurements``) as links to the new pages.

A docstring's ``See Also`` entries (numpydoc: ``rc.evaluate : what it does``, one a line) become
a list of links to the pages of the objects they name.

Hooks: ``on_config`` puts the pages in the nav in place of ``reference/api.md``; ``on_files`` adds
the generated pages; ``on_page_markdown`` writes the module map in place of
``<!-- generated: api-map -->``; ``on_page_content`` links the See Also entries.
"""

from __future__ import annotations

import html
import importlib
import inspect
import json
import re
from functools import cache

API_INDEX = "reference/api.md"
API_DIR = "reference/api"
MAP_MARK = "<!-- generated: api-map -->"
MAP_LINE = 160  # characters of a docstring's first sentence the module map shows

# (task, names): ``rc.X`` is ``import robocal as rc; rc.X``; a longer name is the import path
GROUPS: list[tuple[str, list[str]]] = [
    ("Robot models", ["rc.Robot", "rc.load_model", "rc.Conditions", "rc.Cell", "rc.Positioner",
                      "rc.load_cell", "robocal.kinematics.positioner.positioner_chain"]),
    ("Measurements", ["rc.Measurements", "rc.CellMeasurements", "rc.register",
                      "robocal.data.inputs.check_distinct_inputs", "robocal.data.joint_conventions",
                      "rc.sample_path"]),
    ("Simulated data", ["rc.simulate_tracker", "rc.simulate_markers", "rc.simulate_camera",
                        "rc.simulate_cell", "robocal.data.simulate.SimulationResult"]),
    ("Identification", ["rc.calibrate", "rc.analyze", "rc.CalibrationResult", "rc.CellCalibration",
                        "rc.identify_tcp", "rc.ToolCalibration"]),
    ("Trust and validation", ["rc.evaluate", "robocal.calibration.evaluation.EvaluationResult",
                              "robocal.core.magnitudes", "robocal.trust.output_marker"]),
    ("Compensation", ["rc.compensate", "robocal.deploy.compensation.Compensation",
                      "robocal.deploy.models.load_model_pair"]),
    ("Inverse kinematics", ["rc.ik", "rc.ik.solve_all", "rc.ik.solve", "rc.ik.plan_path", "rc.ik.IKResult",
                            "rc.ik.PathResult", "rc.ik.default_weights"]),
    ("Robot programs", ["rc.filter_program", "rc.FilterResult", "robocal.programs.registry.dialect_for",
                        "robocal.programs.dialects.fanuc.loads.read_schedules"]),
    ("Campaign planning", ["rc.plan_poses", "rc.CampaignResult", "rc.Constraints", "rc.Tracker",
                           "robocal.campaign.CurvePoint", "robocal.campaign.plan_cell",
                           "robocal.campaign.CellCampaignResult", "robocal.campaign.read_candidates",
                           "robocal.campaign.read_planned"]),
    ("History and checks", ["robocal.history.History", "robocal.history.Record",
                            "robocal.history.check.check_calibration", "robocal.history.check.CheckResult",
                            "robocal.history.offsets.recalibrate_offsets"]),
    ("Vendor calibrations (Universal Robots)", [
        "robocal.kinematics.manufacturer.ur.import_calibration",
        "robocal.kinematics.manufacturer.ur.ImportedCalibration",
        "robocal.kinematics.manufacturer.ur.to_ur_calibration",
        "robocal.kinematics.manufacturer.ur.not_representable"]),
    ("ROS descriptions", ["rc.export_urdf_like", "robocal.deploy.urdf_like.UrdfLikeExport"]),
    ("Reports", ["robocal.report.html.write_report", "robocal.report.html.render_report"]),
    ("Errors", ["rc.RobocalError", "rc.DataError", "rc.ModelError", "rc.UnitError", "rc.IdentificationError",
                "rc.PlausibilityError", "rc.UnreachableError"]),
    ("Version", ["rc.__version__"]),
]
# a module's page lists these members only (the rest of the module is internal)
MODULE_MEMBERS = {
    "robocal.core.magnitudes": ["check_length", "check_tool", "check_frame", "check_targets",
                                "check_model_units", "check_degrees", "check_degree_set", "check_radians"],
    "robocal.trust.output_marker": ["model_fingerprint", "find_marker", "check_unmarked", "mark_program",
                                    "mark_csv", "Marker"],
    "robocal.data.joint_conventions": None,  # all its public members
}
# the map's line of a result class whose docstring starts with its fields
MAP_SUMMARY = {
    "robocal.data.simulate.SimulationResult":
        "What a simulation returns: the measurements, the true model, the noise and the outliers.",
    "robocal.deploy.compensation.Compensation":
        "What `compensate` returns: the joints and corrected targets for the controller, and their warnings.",
    "rc.FilterResult":
        "What `filter_program` returns: the filtered programs, the per-target table, the warnings.",
}
SEE_ALSO = re.compile(r'<details class="see-also" open>\s*<summary>See Also</summary>\s*(.*?)</details>',
                      re.S)
SEE_ALSO_ENTRY = re.compile(r"^\s*([\w.]+(?:\s*,\s*[\w.]+)*)\s*(?::\s*(.*))?$")
# a docstring's pointer to a documentation page ("the JSON of docs/result-json.md"): a link on the
# site; a page the docstring names by an older path is the page that now holds it
DOCS_PATH = re.compile(r"(?<![\w/.])docs/((?:[\w-]+/)*[\w-]+\.md)\b")
DOCS_MOVED = {"reference/history-json.md": "reference/history.md#history-json-robocal-history-json",
              "reference/check-json.md": "reference/history.md#check-json-robocal-check-json"}


def names() -> list[str]:
    """Every name of the reference, in the nav's order."""
    return [name for _, group in GROUPS for name in group]


def resolve(name: str) -> object:
    """The object a reference name means: ``rc.ik.solve`` is ``robocal.ik.solve``."""
    path = "robocal" + name[2:] if name.startswith("rc.") else name
    if path == "robocal.__version__":
        return importlib.import_module("robocal.core.version")
    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for attr in parts[cut:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(name)


def target(name: str) -> str:
    """The dotted path where the object is defined (what mkdocstrings renders and anchors)."""
    obj = resolve(name)
    if inspect.ismodule(obj):
        return obj.__name__
    return f"{obj.__module__}.{obj.__qualname__}"


def slug(name: str) -> str:
    """``rc.calibrate`` -> ``calibrate``; ``robocal.history.History`` -> ``history.History``."""
    return name.removeprefix("rc.").removeprefix("robocal.")


def page_uri(name: str) -> str:
    """The generated page's path in the docs (``reference/api/calibrate.md``)."""
    return f"{API_DIR}/{slug(name)}.md"


def summary(name: str) -> str:
    """The docstring's first sentence, for the module map: a long one cut before its first
    parenthesis or last comma within ``MAP_LINE`` characters (the object's page has it all)."""
    if name in MAP_SUMMARY:
        return MAP_SUMMARY[name]
    doc = " ".join((inspect.getdoc(resolve(name)) or "").split("\n\n")[0].split())
    match = re.match(r"(.*?\.)\s+(?=[A-Z`(])", doc)
    first = match.group(1) if match else doc
    if len(first) <= MAP_LINE:
        return first
    cut = first.find(" (")
    if not MAP_LINE // 4 < cut <= MAP_LINE:
        cut = first.rfind(", ", 0, MAP_LINE)
    return first[:cut].rstrip(",;: ") + " …"


def page_markdown(name: str) -> str:
    """The page: a link back to the module map, then mkdocstrings on the object, titled ``name``."""
    path = target(name)
    options = [f"heading: \"{name}\"", "heading_level: 1", "show_root_full_path: false"]
    if inspect.isclass(resolve(name)):
        options.append("summary: {functions: true}")  # a table of the methods at the top of the page
        bases = [b for b in resolve(name).__bases__ if b is not object]
        if bases and all(b.__name__.startswith("_") for b in bases):  # "Bases: _BeforeAfter" says nothing
            options.append("show_bases: false")
    if inspect.ismodule(resolve(name)):
        members = MODULE_MEMBERS.get(path, [])  # [] for rc.ik (its members have their pages), the version
        if members is not None:
            options.append(f"members: [{', '.join(members)}]" if members else "members: false")
    opts = "\n".join(f"      {o}" for o in options)
    back = f"[Python API](../api.md) › {GROUP_OF[name]}"
    return f"{back}\n\n::: {path}\n    options:\n{opts}\n"


GROUP_OF = {name: task for task, group in GROUPS for name in group}


# ----------------------------------------------------------------- the hooks
def on_config(config):
    """The reference's nav: the module map, then one section per task, one page per object."""
    section = [{"Module map": API_INDEX}]
    section += [{task: [{name: page_uri(name)} for name in group]} for task, group in GROUPS]

    def replace(items) -> bool:
        found = False
        for i, item in enumerate(items):
            if isinstance(item, dict):
                for key, value in item.items():
                    if value == API_INDEX:
                        items[i], found = {key: section}, True
                    elif isinstance(value, list):
                        found = replace(value) or found
        return found

    if not replace(config["nav"] or []):
        raise ValueError(f"mkdocs.yml: no nav entry '{API_INDEX}' for the Python API's pages to go under")
    return config


def on_files(files, config):
    from mkdocs.structure.files import File

    for name in names():
        files.append(File.generated(config, page_uri(name), content=page_markdown(name)))
    return files


def module_map() -> str:
    """One table per task: each object's name (its page) and its docstring's first sentence; each
    row carries the object's old anchor (its dotted path)."""
    out = []
    for task, group in GROUPS:
        out += [f"## {task}", "", "| name | what it is |", "|---|---|"]
        for name in group:
            anchor = f'<span id="{target(name)}"></span>'
            text = html.escape(summary(name)).replace("|", "&#124;")
            out.append(f"| {anchor}[`{name}`](api/{slug(name)}.md) | {text} |")
        out.append("")
    return "\n".join(out)


def old_anchors(page, files) -> str:
    """A script that sends a link to an anchor of the old one-page reference
    (``api.md#robocal.kinematics.model.Robot.fk``) on to the object's page (and the method's anchor)."""
    from mkdocs.utils import get_relative_url

    where = {}
    for name in names():
        url = get_relative_url(files.get_file_from_path(page_uri(name)).url, page.url)
        where[target(name)] = url
        obj = resolve(name)
        if inspect.isclass(obj):
            where.update({f"{target(name)}.{m}": f"{url}#{target(name)}.{m}" for m in vars(obj)
                          if not m.startswith("_")})
    return ("<script>(function () { var to = " + json.dumps(where, sort_keys=True) +
            "[decodeURIComponent(location.hash.slice(1))]; if (to) location.replace(to); })();</script>")


def on_page_markdown(markdown, page, config, files):  # noqa: ARG001 - MkDocs' signature
    if MAP_MARK in markdown:
        markdown = markdown.replace(MAP_MARK, module_map() + "\n" + old_anchors(page, files) + "\n")
    return markdown


@cache
def _lookup() -> dict[str, str]:
    """Every way a See Also entry names an object (``rc.evaluate``, ``evaluate``,
    ``robocal.calibration.evaluation.evaluate``, ``Robot.fk``) -> (page slug, anchor)."""
    out = {}
    for name in names():
        obj = resolve(name)
        keys = {name, target(name), name.rsplit(".", 1)[-1], slug(name)}
        if name.startswith("rc."):
            keys.add("robocal." + name[3:])
        for key in keys:
            out.setdefault(key, (slug(name), ""))
        if inspect.isclass(obj):
            short = name.rsplit(".", 1)[-1]
            for member in vars(obj):
                if not member.startswith("_"):
                    for prefix in (name, short, target(name)):
                        out.setdefault(f"{prefix}.{member}", (slug(name), f"{target(name)}.{member}"))
    return out


def see_also_html(block: str, page, files) -> str:
    """The See Also paragraph(s) as a list of links; an entry naming no page is an error."""
    from mkdocs.utils import get_relative_url

    text = re.sub(r"</?p>", "\n", block)
    items, last = [], None
    for line in text.splitlines():
        if not line.strip():
            continue
        match = SEE_ALSO_ENTRY.match(re.sub(r"</?code>", "", line))
        if match is None or not all(n.strip() in _lookup() for n in match.group(1).split(",")):
            if last is None:
                raise ValueError(f"See Also on {page.file.src_uri}: {line.strip()!r} names no page of the "
                                 "API reference")
            items[-1] += " " + line.strip()  # a description continued on the next line
            continue
        links = []
        for entry in (n.strip() for n in match.group(1).split(",")):
            where, anchor = _lookup()[entry]
            url = get_relative_url(files.get_file_from_path(f"{API_DIR}/{where}.md").url, page.url)
            links.append(f'<a href="{url}{"#" + anchor if anchor else ""}"><code>{entry}</code></a>')
        described = line.split(":", 1)[1].strip() if match.group(2) else ""  # its markup kept
        items.append(", ".join(links) + (f": {described}" if described else ""))
        last = entry
    return '<details class="see-also" open><summary>See Also</summary><ul>' + "".join(
        f"<li>{item}</li>" for item in items) + "</ul></details>"


def docs_links(html_text: str, page, files) -> str:
    """``docs/X.md`` in a docstring's prose (not in code) as a link to that page of the site; a path
    that is no page is left as written."""
    from mkdocs.utils import get_relative_url

    def link(match: re.Match) -> str:
        path, _, anchor = DOCS_MOVED.get(match.group(1), match.group(1)).partition("#")
        file = files.get_file_from_path(path)
        if file is None:
            return match.group(0)
        title = file.page.title if file.page is not None and file.page.title else path
        url = get_relative_url(file.url, page.url) + ("#" + anchor if anchor else "")
        return f'<a href="{url}">{html.escape(str(title))}</a>'

    parts = re.split(r"(<pre\b.*?</pre>|<code\b.*?</code>)", html_text, flags=re.S)
    return "".join(part if i % 2 else DOCS_PATH.sub(link, part) for i, part in enumerate(parts))


def on_page_content(html_text, page, config, files):  # noqa: ARG001 - MkDocs' signature
    if page.file.src_uri.startswith(API_DIR + "/"):
        html_text = SEE_ALSO.sub(lambda m: see_also_html(m.group(1), page, files), html_text)
        html_text = docs_links(html_text, page, files)
    return html_text
