"""The site's search ranks what a reader asks for first, the glossary's anchors exist, the changelog
is rendered by version, the version is in every page's header, and no page shows an entity as text.

The search test reads the index the build writes (``search/search_index.json``) and ranks it as the
browser does: lunr 2.3's BM25 fields (k1 1.2, b 0.75, the field boosts of the index's config, a
trailing wildcard on every query term as Material adds it) and Material's post-boost (a page's own
entry x5, a section x2 when every term is found), pages ordered by their best entry. The tokens are
those of the configured pipeline (separator, trimmer, stop words; no stemmer)."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from collections import Counter, defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import docs_site  # noqa: E402

K1, B = 1.2, 0.75  # lunr's BM25 constants
# lunr's English stop words (lunr.js 2.3, MIT licence), as Material's worker ships them
STOP_WORDS = frozenset((
    "a", "able", "about", "across", "after", "all", "almost", "also", "am", "among", "an", "and", "any",
    "are", "as", "at", "be", "because", "been", "but", "by", "can", "cannot", "could", "dear", "did",
    "do", "does", "either", "else", "ever", "every", "for", "from", "get", "got", "had", "has", "have",
    "he", "her", "hers", "him", "his", "how", "however", "i", "if", "in", "into", "is", "it", "its",
    "just", "least", "let", "like", "likely", "may", "me", "might", "most", "must", "my", "neither",
    "no", "nor", "not", "of", "off", "often", "on", "only", "or", "other", "our", "own", "rather",
    "said", "say", "says", "she", "should", "since", "so", "some", "than", "that", "the", "their",
    "them", "then", "there", "these", "they", "this", "tis", "to", "too", "twas", "us", "wants", "was",
    "we", "were", "what", "when", "where", "which", "while", "who", "whom", "why", "will", "with",
    "would", "yet", "you", "your"
))
TAG = re.compile(r"<[^>]+>")
# a reader's query -> the page that must come first
EXPECTED_FIRST = {
    "INFORM": "how-to/programs/inform.html",
    "VAL3": "how-to/programs/val3.html",
    "KRL": "how-to/programs/krl.html",
    "URScript": "how-to/programs/urscript.html",
    "RAPID": "how-to/programs/rapid.html",
    "FANUC": "how-to/programs/fanuc.html",
    "glossary": "glossary.html",
}


def tokens(text: str, separator: re.Pattern) -> list[str]:
    """lunr's tokenizer and the configured pipeline (trimmer, stop-word filter, no stemmer)."""
    out = []
    for raw in separator.split(TAG.sub(" ", text).lower()):
        token = re.sub(r"^\W+|\W+$", "", raw)
        if token and token not in STOP_WORDS:
            out.append(token)
    return out


class SearchIndex:
    """The search index of a built site, scored as lunr and Material score it in the browser."""

    def __init__(self, index: dict):
        config = index["config"]
        assert "stemmer" not in config["pipeline"], "the emulation has no stemmer"
        self.separator = re.compile(config["separator"])
        self.boost = {f: spec.get("boost", 1.0) for f, spec in config["fields"].items()}
        self.docs = index["docs"]
        self.tf: dict[tuple[int, str], Counter] = {}
        self.length: dict[tuple[int, str], int] = {}
        docs_with = defaultdict(set)
        for i, doc in enumerate(self.docs):
            for field in self.boost:
                toks = tokens(doc.get(field) or "", self.separator) if field != "tags" else []
                self.tf[i, field] = Counter(toks)
                self.length[i, field] = len(toks)
                for t in toks:
                    docs_with[t].add(i)
        n = len(self.docs)
        self.avg = {f: sum(self.length[i, f] for i in range(n)) / n for f in self.boost}
        self.idf = {t: math.log(1 + abs((n - len(d) + 0.5) / (len(d) + 0.5))) for t, d in docs_with.items()}

    def weight(self, i: int, field: str, term: str) -> float:
        tf = self.tf[i, field][term]
        if not tf:
            return 0.0
        norm = K1 * (1 - B + B * self.length[i, field] / (self.avg[field] or 1)) + tf
        return round(self.idf[term] * (K1 + 1) * tf / norm * self.boost[field], 3)

    def pages(self, query: str) -> list[str]:
        """The pages in the order the search shows them for ``query``."""
        terms = tokens(query, self.separator)
        expanded = {q: [t for t in self.idf if t.startswith(q)] for q in terms}  # trailing wildcard
        best: dict[str, float] = {}
        for i, doc in enumerate(self.docs):
            found = [q for q in terms if any(self.tf[i, f][t] for t in expanded[q] for f in self.boost)]
            if not found:
                continue
            score = sum(self.weight(i, f, t) / math.sqrt(len(expanded[q]))
                        for q in terms for t in expanded[q] for f in self.boost)
            page, _, anchor = doc["location"].partition("#")
            boost = (0 if anchor else 1) + len(found) / len(terms)
            score *= 1 + boost ** 2
            best[page] = max(best.get(page, 0.0), score)
        return sorted(best, key=best.get, reverse=True)


@pytest.mark.slow
def test_search_ranks_the_page_asked_for_first(site):
    index = SearchIndex(json.loads((site / "search" / "search_index.json").read_text(encoding="utf-8")))
    for query, page in EXPECTED_FIRST.items():
        ranked = index.pages(query)
        assert ranked and ranked[0] == page, f"{query!r}: {ranked[:5]}"
    # "information" is its own word: the campaign page does not come before the INFORM page
    ranked = index.pages("INFORM")
    assert ranked.index("how-to/programs/inform.html") < ranked.index("explanation/campaign.html")
    # a plural finds its pages (with the stemmer it found none: the wildcard query is not stemmed)
    assert len(index.pages("calibrations")) >= 3


@pytest.mark.slow  # a browser
def test_the_browser_ranks_as_the_emulation(site, tmp_path):
    import shutil

    from test_browser import BROWSERS, FLAGS

    browser = next((p for p in map(shutil.which, BROWSERS) if p), None)
    if browser is None:
        pytest.skip("no Chromium found (Debian: apt-get install chromium)")
    index = SearchIndex(json.loads((site / "search" / "search_index.json").read_text(encoding="utf-8")))
    for query in ("INFORM", "FANUC"):
        url = (site / "index.html").as_uri() + f"?q={query}"
        proc = subprocess.run([browser, *FLAGS, f"--user-data-dir={tmp_path / query}",
                               "--virtual-time-budget=10000", "--dump-dom", url],
                              capture_output=True, text=True, timeout=120, check=False)
        shown = re.findall(r'md-search-result__item[^>]*>\s*<a href="([^"?#]+)', proc.stdout)
        assert shown, f"the browser's search showed nothing for {query!r}"
        first = Path(shown[0].removeprefix("file://")).resolve().relative_to(site.resolve()).as_posix()
        assert first == index.pages(query)[0] == EXPECTED_FIRST[query]


@pytest.mark.slow
def test_every_page_shows_the_version_and_no_entity_as_text(site):
    from robocal.core.version import __version__

    pages = [p for p in site.rglob("*.html") if "assets" not in p.parts]
    assert len(pages) > 40
    header = re.compile(r'<div class="md-header__topic">\s*<span class="md-ellipsis">\s*robocal '
                        + re.escape(__version__) + r"\s*</span>")
    for page in pages:
        html = page.read_text(encoding="utf-8")
        if "md-header" not in html:  # a redirect stub or the offline search shim
            continue
        assert header.search(html), f"no version in the header of {page.relative_to(site)}"
        assert not docs_site.literal_entities(html), page.relative_to(site)
    changelog = (site / "changelog.html").read_text(encoding="utf-8")
    assert [m for m in re.findall(r'<h2 id="([^"]+)"', changelog)][:2] == ["unreleased", "v0-6-0"]


def test_the_home_page_cites_this_version():
    from robocal.core.version import __version__

    assert f"Version {__version__}," in (ROOT / "docs" / "index.md").read_text(encoding="utf-8")


def test_literal_entities_are_found_outside_code_blocks():
    assert docs_site.literal_entities("<p>Does <code>x=&amp;quot;auto&amp;quot;</code> lose?</p>")
    assert docs_site.literal_entities("<td>a &amp;lt; b</td>")
    assert not docs_site.literal_entities('<p>x="auto" and &amp; and &lt;</p>')
    assert not docs_site.literal_entities("<pre><code>&amp;quot;shown on purpose&amp;quot;</code></pre>")


def test_changelog_by_version_keeps_every_entry_once():
    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    rendered = docs_site.changelog_by_version(text)
    entries = [line for line in text.splitlines() if line.startswith("- ")]
    assert sorted(line for line in rendered.splitlines() if line.startswith("- ")) == sorted(entries)
    headings = re.findall(r"^## (\S+)", rendered, flags=re.MULTILINE)
    assert headings[0] == "Unreleased,"
    assert headings[1:] == sorted(set(headings[1:]), key=docs_site.version_key)
    assert len(headings) == len(set(headings))  # one section per version
    # every version of the file, dated, newest first after Unreleased
    _, versions = docs_site.parse_changelog(text)
    assert all(v["date"] for k, v in versions.items() if k != docs_site.UNRELEASED)
    assert "0.1.0" in versions and "0.6.0" in versions


def test_changelog_grouping_on_a_small_file():
    text = ("# Changelog\n\nintro\n\n## [Unreleased]\n\n### Added\n- new\n\n## [0.2.0] - 2026-01-02\n\n"
            "### Fixed\n- b1\n\n## [0.1.0] - 2026-01-01\n\n### Added\n- a1\n\n## [0.2.0] - 2026-01-02\n\n"
            "### Added\n- b2\n\n### Fixed\n- b3\n")
    out = docs_site.changelog_by_version(text)
    assert out.index("## 0.2.0") < out.index("### Added\n\n- b2") < out.index("### Fixed\n\n- b1")
    assert out.index("### Fixed\n\n- b1") < out.index("- b3")
    assert out.index("- b3") < out.index("## 0.1.0") < out.index("- a1")
    assert "[0.2.0](#v0-2-0) (2026-01-02)" in out


def test_every_glossary_link_has_its_term():
    glossary = (ROOT / "docs" / "glossary.md").read_text(encoding="utf-8")
    terms = re.findall(r"^\*\*.+?\*\* \{#([a-z0-9-]+)\}$", glossary, flags=re.MULTILINE)
    assert len(terms) == glossary.count("\n**") and len(terms) == len(set(terms))
    new_terms = {"i-optimal", "t-ref", "k", "verdict", "p-value", "check", "cell", "track", "noise-floor"}
    assert set(terms) >= new_terms
    links = []
    for page in (ROOT / "docs").rglob("*.md"):
        text = page.read_text(encoding="utf-8")
        links += [(page, a) for a in re.findall(r"glossary\.md#([A-Za-z0-9_-]+)", text)]
    links += [(ROOT / "docs" / "glossary.md", a) for a in re.findall(r"\]\(#([a-z0-9-]+)\)", glossary)]
    assert len(links) >= 10
    missing = [(str(p.relative_to(ROOT)), a) for p, a in links if a not in terms]
    assert not missing, missing


def test_changelog_entries_stand_under_their_round():
    """The issues an entry names grow with the version it stands under: a line of this round merged
    under an older version's heading (below an inserted `## [0.6.0]`) fails here when it names its
    issue, as most entries do."""
    _, versions = docs_site.parse_changelog((ROOT / "CHANGELOG.md").read_text(encoding="utf-8"))
    named = []
    for version in sorted(versions, key=docs_site.version_key, reverse=True):  # oldest first
        text = " ".join(line for lines in versions[version]["categories"].values() for line in lines)
        issues = {int(n) for n in re.findall(r"\b[Ii]ssues? (\d+)", text)}
        if issues:
            named.append((version, min(issues), max(issues)))
    assert len(named) >= 4
    for (older, _, older_max), (newer, newer_min, _) in zip(named, named[1:], strict=False):
        assert older_max <= newer_min, f"{older} names issue {older_max}, newer than {newer}'s {newer_min}"
