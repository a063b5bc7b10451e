"""MkDocs hook: the pages' formulas as MathML, written into the HTML when the site is built.

``pymdownx.arithmatex`` (generic mode) leaves ``\\( .. \\)`` and ``\\[ .. \\]`` in
``<span class="arithmatex">`` / ``<div class="arithmatex">``; a JavaScript renderer would have to be
fetched or shipped. Browsers render MathML themselves, so the formulas are converted here
(``latex2mathml``) and the site needs no script and no network to show them, served or opened
from disk. A formula the converter cannot read fails the build, naming the page: no raw LaTeX
reaches a reader.
"""

from __future__ import annotations

import html
import re

from latex2mathml.converter import convert

ARITHMATEX = re.compile(r'<(div|span) class="arithmatex">(.*?)</\1>', re.DOTALL)
DELIMITERS = {"div": (r"\[", r"\]"), "span": (r"\(", r"\)")}
# a displayed formula wider than a phone's column (the modified-DH product, 396 px at 390) scrolls
# inside its own box instead of widening the page
BLOCK_BOX = '<div class="math-block" style="overflow-x:auto;max-width:100%">{}</div>'


class FormulaError(ValueError):
    """A formula on a page that cannot be turned into MathML."""


def formulas_to_mathml(content: str, where: str = "") -> str:
    """``content`` (a page's HTML) with every arithmatex formula replaced by MathML."""

    def mathml(match: re.Match) -> str:
        tag, body = match.group(1), html.unescape(match.group(2)).strip()
        opening, closing = DELIMITERS[tag]
        if not (body.startswith(opening) and body.endswith(closing)):
            raise FormulaError(f"formula without {opening} {closing} delimiters{where}: {body[:60]!r}")
        latex = body[len(opening):-len(closing)].strip()
        try:
            if tag == "div":
                return BLOCK_BOX.format(convert(latex, display="block"))
            return convert(latex, display="inline")
        except Exception as exc:  # the converter raises several types for unreadable LaTeX
            raise FormulaError(f"cannot convert the formula {latex[:60]!r}{where}: {exc}") from None

    return ARITHMATEX.sub(mathml, content)


def on_page_content(content: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs' signature
    where = f" (page {page.file.src_path})" if page is not None else ""
    return formulas_to_mathml(content, where)
