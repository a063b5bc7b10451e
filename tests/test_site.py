"""The documentation site as a reader meets it, opened from disk with no network: every nav link
opens a file (not a folder listing), no page shows raw LaTeX, and the search finds pages (headless
Chromium, the file:// worker shim). The site is built once into a temporary folder."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mkdocs", reason="the site needs the docs extra (pip install '.[docs]')")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import docs_math  # noqa: E402
from test_browser import BROWSERS, FLAGS, console_messages  # noqa: E402

RAW_LATEX = re.compile(r"\\\(|\\\)|\\\[|\\\]|\$\$")


def pages(site: Path) -> list[Path]:
    return sorted(p for p in site.rglob("*.html") if "assets" not in p.parts)


@pytest.mark.slow
def test_nav_links_open_files_from_disk(site):
    index = (site / "index.html").read_text(encoding="utf-8")
    links = [h for h in re.findall(r'class="md-nav__link[^"]*"[^>]*href="([^"#]+)"', index)
             + re.findall(r'href="([^"#]+)"[^>]*class="md-nav__link', index) if "://" not in h]
    assert len(set(links)) > 20, links
    for href in set(links):
        target = (site / href).resolve()
        assert target.is_file() and target.suffix == ".html", f"nav link {href} is not a page file"


@pytest.mark.slow
def test_no_page_shows_raw_latex(site):
    formulas = 0
    for page in pages(site):
        text = page.read_text(encoding="utf-8")
        text = re.sub(r"<(pre|code)\b.*?</\1>", "", text, flags=re.DOTALL)  # code may hold backslashes
        assert not RAW_LATEX.search(text), f"raw LaTeX on {page.relative_to(site)}"
        formulas += text.count("<math")
    assert formulas >= 5  # the model and identifiability pages' formulas, as MathML


def test_formula_conversion_and_refusal():
    out = docs_math.formulas_to_mathml('<span class="arithmatex">\\(a &lt; b\\)</span>')
    assert out.startswith("<math") and "&#x0003C;" in out and "arithmatex" not in out
    block = docs_math.formulas_to_mathml('<div class="arithmatex">\\[ x^2 \\]</div>')
    assert 'display="block"' in block
    with pytest.raises(docs_math.FormulaError, match="delimiters"):
        docs_math.formulas_to_mathml('<span class="arithmatex">x^2</span>')


@pytest.mark.slow  # a browser
def test_search_finds_pages_from_disk(site, tmp_path):
    browser = next((p for p in map(shutil.which, BROWSERS) if p), None)
    if browser is None:
        pytest.skip("no Chromium found (Debian: apt-get install chromium; `make test-slow` installs it)")
    url = (site / "index.html").as_uri() + "?q=tracker"
    proc = subprocess.run([browser, *FLAGS, f"--user-data-dir={tmp_path / 'profile'}",
                           "--virtual-time-budget=10000", "--dump-dom", url],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    found = re.search(r'md-search-result__meta">(\d+) matching document', proc.stdout)
    assert found and int(found.group(1)) > 3, "the search found nothing from file://"
    assert proc.stdout.count("md-search-result__item") > 3
    assert not [m for m in console_messages(proc.stderr) if "iframe" in m or "Worker" in m]


@pytest.mark.slow
def test_changelog_glossary_licence_and_citation(site):
    import yaml

    assert "Unreleased" in (site / "changelog.html").read_text(encoding="utf-8")
    assert (site / "glossary.html").read_text(encoding="utf-8").count("<dt id=") >= 15  # a term, an anchor
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    from robocal.core.version import __version__

    assert citation["cff-version"] and citation["version"] == __version__
    assert "MIT License" in (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert 'license = "MIT"' in (ROOT / "pyproject.toml").read_text(encoding="utf-8")
