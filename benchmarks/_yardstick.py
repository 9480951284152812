"""The benchmarks' yardstick: an OpenBLAS dgemm timed in the same process.

Seconds do not carry over between machines; ratios to a dgemm of fixed size measured in
the same process do, much better (``docs/performance.md``).
"""

from __future__ import annotations

import time

import numpy as np


def dgemm_seconds(n: int = 2048, repeat: int = 3) -> float:
    """Best-of-``repeat`` wall time [s] of ``a @ b`` for two (n, n) float64 matrices."""
    a = np.random.default_rng(0).random((n, n))
    b = np.random.default_rng(1).random((n, n))
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        a @ b
        best = min(best, time.perf_counter() - t0)
    return best
