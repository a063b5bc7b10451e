"""A tiny terminal progress bar for long operations (solvers, Monte Carlo, large data sets).

It draws on a terminal only: when the stream is not a TTY (a pipe, a log file, CI) or when
``quiet`` is set it prints nothing, so scripts and logs stay clean. Usage::

    with Progress(200, "genetic", quiet=args.quiet) as bar:
        for generation in range(200):
            ...
            bar.update(info=f"best rms {rms_mm:.4f} mm")

    for item in track(items, "Monte Carlo"):
        ...

``quiet=None`` (the default) follows :func:`set_quiet`, which the command line sets from its
top-level ``--quiet`` flag, so library code need not pass the flag around.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterable, Iterator
from typing import TextIO, TypeVar

T = TypeVar("T")

_DEFAULT_QUIET = False


def set_quiet(quiet: bool) -> None:
    """Set the default for ``quiet=None`` (the CLI calls this with its ``--quiet`` flag)."""
    global _DEFAULT_QUIET
    _DEFAULT_QUIET = bool(quiet)


def _format_time(seconds: float) -> str:
    seconds = int(round(seconds))
    minutes, sec = divmod(seconds, 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{sec:02d}" if hours else f"{minutes:02d}:{sec:02d}"


class Progress:
    """Progress of ``total`` steps (``None`` when unknown) labelled ``label``.

    ``update(n, info)`` advances by ``n`` steps and shows ``info`` (e.g. the current best
    error); redraws are throttled to one per ``min_interval`` seconds, and the final state is
    always drawn on close. ``stream`` defaults to ``sys.stderr``.
    """

    def __init__(self, total: int | None, label: str = "", quiet: bool | None = None,
                 stream: TextIO | None = None, width: int = 30, min_interval: float = 0.1) -> None:
        self.total = None if total is None else max(int(total), 0)
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        quiet = _DEFAULT_QUIET if quiet is None else quiet
        isatty = getattr(self.stream, "isatty", None)
        self.enabled = not quiet and callable(isatty) and bool(isatty())
        self.width = width
        self.min_interval = min_interval
        self.count = 0
        self.info = ""
        self._start = time.monotonic()
        self._last_draw = -float("inf")
        self._last_len = 0
        self._closed = False

    def __enter__(self) -> Progress:
        self._draw(force=True)
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()

    def update(self, n: int = 1, info: str | None = None) -> None:
        """Advance by ``n`` steps; ``info`` replaces the status text shown after the bar."""
        self.count += n
        if info is not None:
            self.info = info
        self._draw(force=self.total is not None and self.count >= self.total)

    def line(self) -> str:
        """The current progress line (without carriage return)."""
        elapsed = _format_time(time.monotonic() - self._start)
        head = f"{self.label}: " if self.label else ""
        if self.total:
            frac = min(self.count / self.total, 1.0)
            filled = int(round(frac * self.width))
            bar = "#" * filled + "." * (self.width - filled)
            text = f"{head}[{bar}] {self.count}/{self.total} {100 * frac:3.0f}% {elapsed}"
        else:
            text = f"{head}{self.count} {elapsed}"
        return f"{text}  {self.info}" if self.info else text

    def _draw(self, force: bool = False) -> None:
        if not self.enabled or self._closed:
            return
        now = time.monotonic()
        if not force and now - self._last_draw < self.min_interval:
            return
        self._last_draw = now
        text = self.line()
        pad = " " * max(self._last_len - len(text), 0)
        self._last_len = len(text)
        self.stream.write("\r" + text + pad)
        self.stream.flush()

    def close(self) -> None:
        """Draw the final state and end the line (idempotent)."""
        if self._closed:
            return
        self._draw(force=True)
        self._closed = True
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


def track(iterable: Iterable[T], label: str = "", total: int | None = None,
          quiet: bool | None = None, stream: TextIO | None = None) -> Iterator[T]:
    """Iterate over ``iterable`` showing a progress bar (``total`` from ``len()`` if omitted)."""
    if total is None and hasattr(iterable, "__len__"):
        total = len(iterable)  # type: ignore[arg-type]
    with Progress(total, label, quiet=quiet, stream=stream) as bar:
        for item in iterable:
            yield item
            bar.update()
