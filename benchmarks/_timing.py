"""Shared by the benchmark scripts: median wall time of repeated calls."""

from __future__ import annotations

import time

import numpy as np


def median_seconds(repeats: int, func, *args) -> float:
    """Median wall time of ``func(*args)`` over ``repeats`` calls, after one warm-up call."""
    func(*args)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func(*args)
        times.append(time.perf_counter() - start)
    return float(np.median(times))
