"""Argument types shared by the subcommands."""

from __future__ import annotations

import argparse
from collections.abc import Callable


def numbers(count: int | None, unit_hint: str) -> Callable[[str], list[float]]:
    """An argparse ``type``: ``count`` comma-separated numbers (e.g. ``X,Y,Z``; None: one or more,
    the command checks how many); ``unit_hint`` completes the error message (e.g. ``"X,Y,Z in mm"``)."""

    def parse(text: str) -> list[float]:
        try:
            values = [float(v) for v in text.replace(" ", "").split(",") if v]
        except ValueError:
            values = []
        if not values or (count is not None and len(values) != count):
            raise argparse.ArgumentTypeError(f"expected {count or 'some'} comma-separated numbers "
                                             f"({unit_hint}), got {text!r}")
        return values

    return parse


def print_warnings(command: str, warnings) -> None:
    """The warnings of a quiet run on stderr, one line each (``--quiet`` silences progress and
    summaries, never a warning)."""
    import sys

    for warning in warnings:
        print(f"robocal {command}: warning: {' '.join(str(warning).split())}", file=sys.stderr)
