"""MkDocs hook: the site's version, the changelog by version, and a check on the rendered text.

- The package version (``robocal.core.version.__version__``) is written into the site name, so the
  header of every page shows it (``robocal 0.7.0``).
- The changelog page (``docs/changelog.md``, which includes ``CHANGELOG.md``) is rendered one
  section per version, newest first, with a version index at the top. ``CHANGELOG.md`` is only
  ever extended by inserting lines: an older version may stand under several headings there (its
  entries where they were written); here its entries are gathered under one heading per
  category, in the order of the file.
- A page whose text shows an HTML entity literally (``&quot;auto&quot;`` on the page: the source
  escaped it twice) fails the build, naming the page and the text. Code blocks and inline code
  may show entities on purpose and are not checked.
"""

from __future__ import annotations

import re
from pathlib import Path

from robocal.core.version import __version__

ROOT = Path(__file__).resolve().parents[1]
CHANGELOG = ROOT / "CHANGELOG.md"
CHANGELOG_PAGE = "changelog.md"
VERSION_HEADING = re.compile(r"^## \[(?P<version>[^\]]+)\](?: - (?P<date>\d{4}-\d{2}-\d{2}))?\s*$")
CATEGORY_HEADING = re.compile(r"^### (?P<category>\S.*?)\s*$")
CATEGORY_ORDER = ("Added", "Changed", "Deprecated", "Removed", "Fixed", "Security")
UNRELEASED = "Unreleased"
# an entity escaped twice: the reader sees "&quot;" instead of a quotation mark
DOUBLE_ESCAPED = re.compile(r"&amp;(?:[a-zA-Z][a-zA-Z0-9]{1,31}|#[0-9]{1,7}|#[xX][0-9a-fA-F]{1,6});")
CODE_BLOCK = re.compile(r"<pre\b.*?</pre>", re.DOTALL)
HTML_COMMENT = re.compile(r"<!--.*?-->", re.DOTALL)


class LiteralEntityError(ValueError):
    """A page shows an HTML entity as text (its source escaped it twice)."""


def on_config(config, **kwargs):  # noqa: ARG001 - MkDocs' signature
    base = config["site_name"].split()[0]
    config["site_name"] = f"{base} {__version__}"
    config.setdefault("extra", {})["robocal_version"] = __version__
    return config


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs' signature
    if page is not None and page.file.src_uri == CHANGELOG_PAGE:
        return changelog_by_version(CHANGELOG.read_text(encoding="utf-8"))
    return markdown


def on_post_page(output: str, page, config) -> str:  # noqa: ARG001 - MkDocs' signature
    where = page.file.src_uri if page is not None else "a page"
    literal = literal_entities(output)
    if literal:
        shown = "; ".join(literal[:5])
        raise LiteralEntityError(f"{where} shows {len(literal)} HTML entit(ies) as text (escaped twice "
                                 f"in its source): {shown}")
    return output


def literal_entities(page_html: str) -> list[str]:
    """The double-escaped entities of a page's HTML outside code, each with the text around it."""
    text = CODE_BLOCK.sub("", HTML_COMMENT.sub("", page_html))
    return [text[max(0, m.start() - 30):m.end() + 30].replace("\n", " ")
            for m in DOUBLE_ESCAPED.finditer(text)]


def version_key(version: str) -> tuple:
    """Newest first: Unreleased, then the numbered versions in descending order."""
    if version == UNRELEASED:
        return (0,)
    return (1, *(-int(p) if p.isdigit() else 0 for p in re.split(r"[.+-]", version)))


def version_anchor(version: str) -> str:
    return "unreleased" if version == UNRELEASED else "v" + re.sub(r"[^0-9a-zA-Z]+", "-", version)


def parse_changelog(text: str) -> tuple[list[str], dict[str, dict]]:
    """The preamble's lines and, per version, ``{"date", "notes", "categories": {name: lines}}``:
    the lines under each (version, category) heading pair, in the order of the file."""
    preamble: list[str] = []
    versions: dict[str, dict] = {}
    current: dict | None = None
    category: str | None = None
    for line in text.splitlines():
        heading = VERSION_HEADING.match(line)
        if heading:
            current = versions.setdefault(heading["version"], {"date": None, "notes": [], "categories": {}})
            current["date"] = current["date"] or heading["date"]
            category = None
            continue
        if current is None:
            preamble.append(line)
            continue
        sub = CATEGORY_HEADING.match(line)
        if sub:
            category = sub["category"]
            current["categories"].setdefault(category, [])
            continue
        (current["notes"] if category is None else current["categories"][category]).append(line)
    return preamble, versions


def _block(lines: list[str]) -> list[str]:
    """Lines without leading and trailing blank lines."""
    start, end = 0, len(lines)
    while start < end and not lines[start].strip():
        start += 1
    while end > start and not lines[end - 1].strip():
        end -= 1
    return lines[start:end]


def changelog_by_version(text: str) -> str:
    """The changelog's Markdown with one section per version (newest first) and a version index."""
    preamble, versions = parse_changelog(text)
    order = sorted(versions, key=version_key)
    out = _block(preamble) + [""]
    index = []
    for v in order:
        date = versions[v]["date"]
        label = f"{v} ({__version__}, this version)" if v == UNRELEASED else v
        index.append(f"[{label}](#{version_anchor(v)})" + (f" ({date})" if date else ""))
    out += ["Versions: " + " · ".join(index), ""]
    for v in order:
        entry = versions[v]
        title = f"{v}, the package's version {__version__}" if v == UNRELEASED else v
        out += [f"## {title}" + (f" ({entry['date']})" if entry["date"] else "")
                + f" {{#{version_anchor(v)}}}", ""]
        notes = _block(entry["notes"])
        if notes:
            out += notes + [""]
        names = sorted(entry["categories"], key=lambda c: (CATEGORY_ORDER.index(c)
                                                            if c in CATEGORY_ORDER else len(CATEGORY_ORDER)))
        for name in names:
            # a category's runs, each without its surrounding blank lines: one list per category
            body = _block(entry["categories"][name])
            if body:
                out += [f"### {name}", ""] + body + [""]
    return "\n".join(out) + "\n"
