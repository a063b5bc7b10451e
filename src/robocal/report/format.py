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


def p_value(value) -> str:
    """A test's p-value with two significant digits (escaped as it is when not a number)."""
    return f"{value:.2g}" if isinstance(value, float) else esc(value)


KEEP_ROWS = 15  # a table of at most this many rows is not split across printed pages


def table(header: list[str], rows: list[list[str]], left: int = 1, row_class=None,
          align: str | None = None) -> str:
    """Rows of pre-escaped cells; the first ``left`` columns are left-aligned, or ``align`` gives
    each column's alignment (``"l"`` left, ``"r"`` right, ``"w"`` left and wrapping)."""
    align = align or "l" * left + "r" * max(len(header) - left, 0)
    css = {"l": ' class="l"', "w": ' class="l wrap"', "r": ""}

    def cls(k: int) -> str:
        return css[align[k]] if k < len(align) else ""

    head = "".join(f"<th{cls(k)}>{h}</th>" for k, h in enumerate(header))
    body = []
    for i, r in enumerate(rows):
        rc = f' class="{row_class[i]}"' if row_class and row_class[i] else ""
        body.append(f"<tr{rc}>" + "".join(f"<td{cls(k)}>{c}</td>" for k, c in enumerate(r)) + "</tr>")
    markup = f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"
    keep = " keep" if len(rows) <= KEEP_ROWS else ""  # kept on one printed page
    return f"<div class='scroll{keep}'>{markup}</div>"


def joint_columns(result: dict, n: int, external: int = 0) -> list[tuple[str, str]]:
    """Each of ``n`` joints' ``(name, unit)`` of a result or campaign dict: from its ``robot.joints``
    columns (``q3_mm``, a track's ``e1_mm``: written when a joint is prismatic, see
    `robocal.kinematics.model.Robot.section`), else (an older file) ``external`` track carriages
    ``e1..`` in mm, then revolute joints ``q1..`` in deg."""
    columns = (result.get("robot") or {}).get("joints")
    if not isinstance(columns, list) or len(columns) != n:
        return [(f"e{i + 1}", "mm") if i < external else (f"q{i - external + 1}", "deg") for i in range(n)]
    return [tuple(str(c).rpartition("_")[::2]) for c in columns]
