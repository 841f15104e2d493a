"""A pool of threads for a few long jobs (the simulated steps of a ride) that stops at once when interrupted.

:func:`run_threads` runs them on threads: the native closed loop
(:mod:`euc_sim.simulation.native`) steps in C without the GIL, so the steps of a ride
ride side by side in one process, with nothing pickled and no memory copied.  Each job
gets a ``cancel`` event; an interruption in the calling thread sets it, and a job that
looks at it (:func:`euc_sim.rides.sim.tracking.simulate_profile`'s clock, at every rider
block) ends at once instead of riding its minutes out.  Jobs that hold the GIL go to
processes: :func:`euc_sim.simulation.runner.run_tasks`.
"""

from __future__ import annotations

import threading
from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait
from typing import Any, Callable, Sequence

__all__ = ["run_threads"]


def run_threads(fn: Callable[[Any, Any], Any], jobs: Sequence, workers: int,
                on_done: Callable[[int, int], None] | None = None) -> list:
    """``[fn(job, cancel) for job in jobs]``, on ``workers`` threads when more than 1.

    Parameters
    ----------
    fn : callable
        ``fn(job, cancel)``; ``cancel`` is a :class:`threading.Event` set when the caller is
        interrupted (or another job failed): a long job should end when it is set.
    jobs : sequence
        Its first arguments.
    workers : int
        Threads; 1 runs each job in this thread, in order.
    on_done : callable, optional
        ``on_done(index, n_done)`` in this thread as each job ends.

    Returns
    -------
    list
        Results in the order of ``jobs``; the first job's exception (in the order jobs
        end) is re-raised here, the other jobs stopped first.
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

