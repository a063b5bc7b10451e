"""Argument types shared by the subcommands."""

from __future__ import annotations

import argparse
from collections.abc import Callable


def numbers(count: int, unit_hint: str) -> Callable[[str], list[float]]:
    """An argparse ``type``: ``count`` comma-separated numbers (e.g. ``X,Y,Z``); ``unit_hint``
    completes the error message (e.g. ``"X,Y,Z in mm"``)."""

    def parse(text: str) -> list[float]:
        try:
            values = [float(v) for v in text.replace(" ", "").split(",") if v]
        except ValueError:
            values = []
        if len(values) != count:
            raise argparse.ArgumentTypeError(f"expected {count} comma-separated numbers ({unit_hint}), "
                                             f"got {text!r}")
        return values

    return parse
