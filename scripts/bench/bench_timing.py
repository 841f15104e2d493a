"""Timing helpers of the benchmarks (``scripts/bench.py``): best wall times, interleaved runs."""

from __future__ import annotations

import os
import threading
import time
from typing import Callable, Sequence

os.environ.setdefault("MPLBACKEND", "Agg")


def timed(fn: Callable[[], object], repeat: int = 3) -> float:
    """Best wall time of ``repeat`` runs, s."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def timed_together(fns: dict[str, Callable[[], object]], repeat: int = 5) -> dict[str, float]:
    """Best wall time of each, s, the runs interleaved (round robin): on a shared machine a
    burst of load then hits every contender of a ratio alike, not one of them."""
    best = {k: float("inf") for k in fns}
    for _ in range(repeat):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            best[k] = min(best[k], time.perf_counter() - t0)
    return best


def at_once(fn: Callable[..., object], kwargs: Sequence[dict]) -> None:
    """Run ``fn(**kw)`` for every ``kw`` on threads of its own at the same time, and wait for
    all: the two-thread ceiling of a C loop that releases the GIL."""
    lanes = [threading.Thread(target=fn, kwargs=kw) for kw in kwargs]
    for t in lanes:
        t.start()
    for t in lanes:
        t.join()
