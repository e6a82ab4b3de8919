"""Wall-clock timing: best of a few runs (benchmarks and the experiments' speed tables)."""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["best_time", "best_time_and_result"]


def best_time_and_result(fn: Callable[[], object], *, repeats: int = 3) -> tuple[float, object]:
    """The shortest ``time.perf_counter`` wall time of ``repeats`` calls, and the last result."""
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def best_time(fn: Callable[[], object], *, repeats: int = 3) -> float:
    """The shortest wall time of ``repeats`` calls of ``fn``."""
    return best_time_and_result(fn, repeats=repeats)[0]
