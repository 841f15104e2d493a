"""Pools for a few long jobs (the simulated steps of a ride) that stop at once when interrupted.

:func:`run_threads` runs them on threads: the native closed loop
(:mod:`euc_sim.simulation.native`) steps in C without the GIL, so the steps of a ride
ride side by side in one process, with nothing pickled and no memory copied.  Each job
gets a ``cancel`` event; an interruption in the calling thread sets it, and a job that
looks at it (:func:`euc_sim.rides.sim.tracking.simulate_profile`'s clock, at every rider
block) ends at once instead of riding its minutes out.

:func:`run_jobs` runs them in processes (jobs that hold the GIL).
``ProcessPoolExecutor`` alone leaves workers running when the parent is killed (SIGKILL)
and, when the parent is interrupted, waits for the running jobs to end (minutes of a
ride simulation).  :func:`run_jobs` makes each worker ignore Ctrl-C
(the parent handles it), die with the parent (Linux ``prctl(PR_SET_PDEATHSIG,
SIGKILL)``), and kills the workers when the parent is interrupted
(``KeyboardInterrupt``: Ctrl-C, or SIGTERM as ``euc-sim`` handles it).
"""

from __future__ import annotations

import os
from typing import Any, Callable, Sequence

from euc_sim.simulation.runner import worker_init

__all__ = ["run_jobs", "run_threads"]


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
    import threading
    from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait

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


def run_jobs(fn: Callable[[Any], Any], jobs: Sequence, workers: int,
             on_done: Callable[[int, int], None] | None = None) -> list:
    """``[fn(job) for job in jobs]``, in ``workers`` forked processes when more than 1.

    Parameters
    ----------
    fn : callable
        A module-level function (picklable) of one argument.
    jobs : sequence
        Its arguments (picklable).
    workers : int
        Processes; 1 runs in this process, in order.
    on_done : callable, optional
        ``on_done(index, n_done)`` in this process as each job ends.

    Returns
    -------
    list
        Results in the order of ``jobs`` (a job's exception is re-raised here).

    Raises
    ------
    ChildProcessError
        (an ``OSError``) when a worker process dies without a result.
    """
    note = on_done or (lambda i, k: None)
    if workers <= 1 or len(jobs) <= 1:
        out = []
        for i, job in enumerate(jobs):
            out.append(fn(job))
            note(i, len(out))
        return out
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    pool = ProcessPoolExecutor(min(workers, len(jobs)), mp_context=multiprocessing.get_context("fork"),
                               initializer=worker_init, initargs=(os.getpid(),))
    done: dict[int, Any] = {}
    try:
        futures = {pool.submit(fn, job): i for i, job in enumerate(jobs)}
        for fut in as_completed(futures):
            try:
                done[futures[fut]] = fut.result()
            except BrokenProcessPool:
                raise ChildProcessError(f"a worker process died during job {futures[fut] + 1} of "
                                        f"{len(jobs)} (killed, e.g. by the system when memory "
                                        f"ran out)") from None
            note(futures[fut], len(done))
    except BaseException:
        for proc in list((getattr(pool, "_processes", None) or {}).values()):
            proc.kill()
        # Wait for the pool's manager thread, which ends at once with its workers dead: left
        # running, it can close its wake-up pipe while the interpreter's exit hook writes to it
        # (concurrent.futures.process._python_exit), which prints "Exception ignored in ..."
        # and a traceback after the interruption message.
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return [done[i] for i in range(len(jobs))]
