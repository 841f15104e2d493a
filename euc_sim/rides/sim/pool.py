"""A pool of threads for a few long jobs (the simulated steps of a ride) that stops at once when interrupted.

The native closed loop steps in C without the GIL, so a ride's steps ride side by side
on threads.  Each job gets a ``cancel`` event, set on an interruption; jobs holding the
GIL go to processes (:func:`euc_sim.simulation.runner.run_tasks`).
"""

from __future__ import annotations

import threading
from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait
from typing import Any, Callable, Sequence

__all__ = ["run_threads"]


def run_threads(fn: Callable[[Any, Any], Any], jobs: Sequence, workers: int,
                on_done: Callable[[int, int], None] | None = None) -> list:
    """``[fn(job, cancel) for job in jobs]``, on ``workers`` threads when more than 1.

    ``cancel`` (a :class:`threading.Event`) is set when the caller is interrupted or a job
    failed; ``on_done(index, n_done)`` is called in this thread as each job ends.  Results
    in the order of ``jobs``; the first failing job's exception is re-raised, the others stopped.
    """
    note = on_done or (lambda i, k: None)
    cancel = threading.Event()
    if workers <= 1 or len(jobs) <= 1:
        out = []
        for i, job in enumerate(jobs):
            out.append(fn(job, cancel))
            note(i, len(out))
        return out
    pool = ThreadPoolExecutor(min(workers, len(jobs)), thread_name_prefix="euc-sim-step")
    done: dict[int, Any] = {}
    try:
        futures = {pool.submit(fn, job, cancel): i for i, job in enumerate(jobs)}
        pending = set(futures)
        while pending:
            finished, pending = wait(pending, return_when=FIRST_EXCEPTION)
            for fut in finished:
                done[futures[fut]] = fut.result()         # a job's exception: raised here
                note(futures[fut], len(done))
    except BaseException:
        cancel.set()                # the running jobs end at their next look; none starts
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return [done[i] for i in range(len(jobs))]

