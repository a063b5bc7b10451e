"""Best-of-n timing shared by the benchmarks."""

from __future__ import annotations

import time


def best_time(fn, repeat: int = 3, clock=time.perf_counter) -> tuple[float, object]:
    """``(shortest time in s, last result)`` of ``repeat`` calls of ``fn``."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t = clock()
        out = fn()
        best = min(best, clock() - t)
    return best, out
