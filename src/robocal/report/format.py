"""Numbers and text as the report writes them: escaped, with a fixed number of digits."""

from __future__ import annotations

import html
import math


def esc(value) -> str:
    """HTML-escaped text of any value (user strings, numbers, None)."""
    return html.escape("" if value is None else str(value), quote=True)


def num(value, digits: int = 4) -> str:
    """A number with ``digits`` decimals (scientific where tiny or huge), '&ndash;' for None."""
    if value is None:
        return "&ndash;"
    if isinstance(value, bool) or not isinstance(value, int | float):
        return esc(value)
    if not math.isfinite(value):
        return esc(value)
    if isinstance(value, int):
        return str(value)
    if value != 0 and (abs(value) >= 1e6 or abs(value) < 10 ** (-digits)):
        return f"{value:.{min(digits, 4)}g}" if abs(value) >= 1e6 else f"{value:.3e}"
    return f"{value:.{digits}f}"
