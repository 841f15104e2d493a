"""A process pool for a few long jobs that dies with its parent and stops at once.

``ProcessPoolExecutor`` alone leaves workers running when the parent is killed
(SIGKILL) and, when the parent is interrupted, waits for the running jobs to end
(minutes of a ride simulation).  :func:`run_jobs` makes each worker ignore Ctrl-C
(the parent handles it), die with the parent (Linux ``prctl(PR_SET_PDEATHSIG,
SIGKILL)``), and kills the workers when the parent is interrupted
(``KeyboardInterrupt``: Ctrl-C, or SIGTERM as ``euc-sim`` handles it).
"""

from __future__ import annotations

import os
from typing import Any, Callable, Sequence

from euc_sim.simulation.runner import worker_init

__all__ = ["run_jobs"]


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
