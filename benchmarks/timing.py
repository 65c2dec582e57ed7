"""Shared timing helper of the benchmark scripts (run them as ``python benchmarks/<name>.py``: this folder is first
on ``sys.path``)."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable


def call_rate(fn: Callable[[], object], n: int, repeats: int) -> tuple[float, float, float]:
    """Calls per second of ``fn`` over ``repeats`` timed rounds of ``n`` calls, after one untimed warm-up call:
    ``(median, lowest, highest)``."""
    fn()  # warm-up (compiled kernels load from their cache)
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        rates.append(n / (time.perf_counter() - t0))
    return statistics.median(rates), min(rates), max(rates)
