"""The gallery of worked examples: run each script of ``examples/gallery`` once, cache what it printed
and drew by the script's hash, and (as a MkDocs hook) render a page per example and the thumbnails.

An example is a plain Python script: a docstring (a title, a line of ``=``, the explanation), then
sections that each start with a ``# %% heading`` comment. It is run as its reader would run it
(``python NN_name.py`` in an empty folder, matplotlib without a display), one section after the
other in one namespace, so that the page can show each section's code with what it printed and the
figures (``*.png`` in the working folder) it wrote.

The outputs are cached in ``build/gallery/<stem>/<hash>/`` (``output.json`` and the figures): a site
build runs a script only when the cache of its current text is missing. ``make gallery`` (which
``make docs`` runs first) and ``tests/test_gallery.py`` run them and fill the cache;
``python scripts/docs_gallery.py [--force] [stem ...]`` does the same by hand.

The hook adds to the site, under ``gallery/``: ``<stem>.md`` (the page), ``<stem>.py`` (the script,
downloadable) and ``<stem>_<k>.png`` (its figures); the marker ``<!-- generated: gallery -->`` of
``docs/gallery/index.md`` becomes the thumbnails.
"""

from __future__ import annotations

import argparse
import ast
import hashlib
import html
import json
import os
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GALLERY = ROOT / "examples" / "gallery"
CACHE = ROOT / "build" / "gallery"
SITE_FOLDER = "gallery"  # where the pages, scripts and figures go in the site
INDEX_MARK = "<!-- generated: gallery -->"
CELL_MARK = "# %%"
SENTINEL = "\x1egallery-cell-end "  # printed after each section by the runner, then its new figures
RUN_TIMEOUT_S = 600  # one script; the gallery's whole run is meant to stay under ~2 min

# Runs in the child: each section in turn, in one namespace, line numbers as in the file; after each,
# the sentinel and the figures that appeared in the working folder.
_RUNNER = r"""
import json, sys
from pathlib import Path
script, sentinel = sys.argv[1], sys.argv[2]
sections = json.loads(sys.stdin.read())
namespace = {"__name__": "__main__", "__file__": Path(script).name}
seen = set()
for first_line, code in sections:
    exec(compile("\n" * (first_line - 1) + code, script, "exec"), namespace)
    new = sorted(p.name for p in Path(".").glob("*.png") if p.name not in seen)
    seen.update(new)
    print(sentinel + json.dumps(new), flush=True)
"""


class GalleryError(RuntimeError):
    """An example is malformed or failed when it ran."""


@dataclass(frozen=True)
class Section:
    """A ``# %%`` section of an example: its heading (empty for the imports), its code and the line
    it starts on (1-based)."""

    heading: str
    code: str
    first_line: int


@dataclass(frozen=True)
class Example:
    """An example script: its path, title, explanation (Markdown) and sections."""

    path: Path
    title: str
    intro: str
    sections: tuple[Section, ...]

    @property
    def stem(self) -> str:
        return self.path.stem

    @property
    def digest(self) -> str:
        """The first 16 hex digits of the script's SHA-256: the key of its cached outputs."""
        return hashlib.sha256(self.path.read_bytes()).hexdigest()[:16]


def parse_example(path: Path) -> Example:
    """The title, explanation and sections of the script at ``path``."""
    text = path.read_text(encoding="utf-8")
    module = ast.parse(text, str(path))
    doc = ast.get_docstring(module)
    if not doc or not isinstance(module.body[0], ast.Expr):
        raise GalleryError(f"{path.name}: an example starts with a docstring (title, '===' line, text)")
    lines = doc.splitlines()
    if len(lines) < 2 or set(lines[1].strip()) != {"="}:
        raise GalleryError(f"{path.name}: the docstring's first line is the title, underlined with '='")
    start = module.body[0].end_lineno
    chunks: list[tuple[str, list[tuple[int, str]]]] = [("", [])]
    for number, line in enumerate(text.splitlines()[start:], start=start + 1):
        if line.startswith(CELL_MARK):
            chunks.append((line[len(CELL_MARK):].strip(), []))
        else:
            chunks[-1][1].append((number, line))
    sections = []
    for heading, numbered in chunks:
        kept = [k for k, (_, line) in enumerate(numbered) if line.strip()]
        if kept:
            body = numbered[kept[0]:kept[-1] + 1]
            sections.append(Section(heading, "\n".join(line for _, line in body), body[0][0]))
    if not any(s.heading for s in sections):
        raise GalleryError(f"{path.name}: no '{CELL_MARK} heading' section")
    intro = re.sub(r"``(.+?)``", r"`\1`", "\n".join(lines[2:]).strip())  # reST literals as Markdown's
    return Example(path, lines[0].strip(), intro, tuple(sections))


def examples() -> list[Example]:
    """Every example of the gallery, in file-name order."""
    return [parse_example(p) for p in sorted(GALLERY.glob("[0-9][0-9]_*.py"))]


# ----------------------------------------------------------------- running and caching
def cache_dir(example: Example) -> Path:
    return CACHE / example.stem / example.digest


def cached(example: Example) -> dict | None:
    """The cached outputs of the example's current text, or None when there are none (complete)."""
    try:
        out = json.loads((cache_dir(example) / "output.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    figures = [f for section in out["sections"] for f in section["figures"]]
    return out if all((cache_dir(example) / f).is_file() for f in figures) else None


def run_example(example: Example, timeout: float = RUN_TIMEOUT_S) -> dict:
    """Run the example in an empty folder and cache what each section printed and drew.

    Returns ``{"script", "digest", "seconds", "sections": [{"heading", "output", "figures"}]}``
    (``figures``: file names in `cache_dir`). Raises GalleryError if the script fails.
    """
    stem_dir = CACHE / example.stem
    stem_dir.mkdir(parents=True, exist_ok=True)
    work = stem_dir / f".run-{os.getpid()}"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir()
    sections = [(s.first_line, s.code) for s in example.sections]
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": os.pathsep.join(
        [str(ROOT / "src"), *filter(None, [os.environ.get("PYTHONPATH")])])}
    start = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-c", _RUNNER, str(example.path), SENTINEL],
                              input=json.dumps(sections), capture_output=True, text=True, cwd=work,
                              env=env, timeout=timeout)
    except subprocess.TimeoutExpired:
        shutil.rmtree(work, ignore_errors=True)
        raise GalleryError(f"{example.path.name} ran longer than {timeout:g} s") from None
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        shutil.rmtree(work, ignore_errors=True)
        raise GalleryError(f"{example.path.name} failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}")
    # stdout: text 0, sentinel, figures 0, newline, text 1, sentinel, figures 1, newline, ...
    parts = proc.stdout.split(SENTINEL)
    texts, figures = [parts[0]], []
    for part in parts[1:]:
        line, _, text = part.partition("\n")
        figures.append(json.loads(line))
        texts.append(text)
    out_sections = [{"heading": section.heading, "output": text, "figures": names}
                    for section, text, names in zip(example.sections, texts[:-1], figures, strict=True)]
    final = cache_dir(example)
    shutil.rmtree(final, ignore_errors=True)
    final.mkdir(parents=True)
    for section in out_sections:
        for name in section["figures"]:
            shutil.move(work / name, final / name)
    out = {"script": example.path.name, "digest": example.digest, "seconds": round(seconds, 2),
           "sections": out_sections}
    tmp = final / "output.json.tmp"
    tmp.write_text(json.dumps(out, indent=1), encoding="utf-8")
    tmp.replace(final / "output.json")
    shutil.rmtree(work, ignore_errors=True)
    for old in stem_dir.iterdir():  # the outputs of earlier versions of the script
        if old.is_dir() and old.name != final.name and not old.name.startswith(".run-"):
            shutil.rmtree(old, ignore_errors=True)
    return out


def outputs(example: Example) -> dict:
    """The cached outputs of the example, running it first when there are none."""
    return cached(example) or run_example(example)


# ----------------------------------------------------------------- pages
def figure_name(example: Example, k: int) -> str:
    return f"{example.stem}_{k}.png"


def _figures(example: Example, out: dict) -> list[tuple[str, str]]:
    """(cached file name, site file name) of every figure, in order."""
    names = [f for section in out["sections"] for f in section["figures"]]
    return [(name, figure_name(example, k + 1)) for k, name in enumerate(names)]


def page_markdown(example: Example, out: dict) -> str:
    """The example's page: title, explanation, download, then each section's code, output, figures."""
    site_names = dict(_figures(example, out))
    # no table of contents beside the code: the code gets the width of the page (~110 characters)
    md = ["---", "hide:", "  - toc", "---", "", f"# {example.title}", "", example.intro, "",
          f'[Download `{example.path.name}`]({example.path.name}){{ download="'
          f'{example.path.name}" }} &nbsp; Run it with `python {example.path.name}` in an empty folder '
          f"(robocal with its `report` extra, which brings matplotlib); it took {out['seconds']:.0f} s "
          "when this page was built.", ""]
    for section, result in zip(example.sections, out["sections"], strict=True):
        if section.heading:
            md += [f"## {section.heading}", ""]
        md += ["```python", section.code, "```", ""]
        text = result["output"].rstrip()
        if text:
            body = "\n".join("    " + line for line in text.splitlines())
            md += ['???+ success "Output"', "", "    ```text", body, "    ```", ""]  # open, foldable
        for name in result["figures"]:
            md += [f"![{section.heading or example.title}]({site_names[name]})", ""]
    return "\n".join(md)


def index_markdown(items: list[tuple[Example, dict]]) -> str:
    """The thumbnails: a card per example (its first figure, title and first sentence)."""
    cards = []
    for example, out in items:
        figures = _figures(example, out)
        thumb = (f'<a href="{example.stem}.html"><img src="{figures[0][1]}" alt="" loading="lazy"></a>'
                 if figures else "")
        first = example.intro.replace("\n", " ").split(". ")[0].rstrip(".") + "."
        first = re.sub(r"`(.+?)`", r"<code>\1</code>", html.escape(first))
        cards.append(f'<li>{thumb}<p><a href="{example.stem}.html"><strong>{html.escape(example.title)}'
                     f"</strong></a></p><p>{first}</p></li>")
    return '<div class="grid cards gallery">\n<ul>\n' + "\n".join(cards) + "\n</ul>\n</div>"


# ----------------------------------------------------------------- MkDocs hook
_BUILT: list[tuple[Example, dict]] = []


def on_files(files, config):
    """Add each example's page, script and figures to the site (running the scripts not cached)."""
    from mkdocs.structure.files import File

    _BUILT.clear()
    for example in examples():
        out = outputs(example)
        _BUILT.append((example, out))
        folder = f"{SITE_FOLDER}/"
        files.append(File.generated(config, folder + f"{example.stem}.md",
                                    content=page_markdown(example, out)))
        files.append(File.generated(config, folder + example.path.name, content=example.path.read_bytes()))
        for cached_name, site_name in _figures(example, out):
            files.append(File.generated(config, folder + site_name,
                                        content=(cache_dir(example) / cached_name).read_bytes()))
    return files


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs' signature
    if INDEX_MARK in markdown:
        built = _BUILT or [(example, outputs(example)) for example in examples()]
        markdown = markdown.replace(INDEX_MARK, index_markdown(built))
    return markdown


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Run the gallery's examples whose outputs are not cached.")
    parser.add_argument("stems", nargs="*", help="only these examples (file names without .py)")
    parser.add_argument("--force", action="store_true", help="run them even when cached")
    args = parser.parse_args(argv)
    total = 0.0
    for example in examples():
        if args.stems and example.stem not in args.stems:
            continue
        out = None if args.force else cached(example)
        state = "cached"
        if out is None:
            out, state = run_example(example), "ran"
            total += out["seconds"]
        print(f"{example.stem}: {state} ({out['seconds']:.1f} s)")
    print(f"gallery: {total:.1f} s of runs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
