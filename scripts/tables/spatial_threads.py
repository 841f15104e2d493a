"""Many 3-D rides at once for the blind study: :func:`~euc_sim.simulation.spatial.simulate_3d` on threads.

The planar rides of a study go to ``mujoco.batch.Batch``
(:mod:`euc_sim.simulation.mujoco_batch`); the 3-D rides run natively, one ``MjData`` each,
with the numba control callback of :mod:`euc_sim.simulation.native_spatial`.  That
callback serves every registered ``MjData`` through its own context
(:mod:`euc_sim.simulation.native_core`) and never takes the GIL, and ``mj_step``
releases it, so rides on different threads step in C at once; only their set-up (the
lateral design, the path, the context) and their DataFrames hold the GIL.

Exact: a ride on a thread is the ride :func:`simulate_3d` makes alone, bit for bit
(``tests/scripts/tables/test_spatial_threads.py``): each ride's state lives in its own
``MjData`` and context, nothing is shared between rides but read-only models and the
callback's registry; BLAS is held to one thread during the rides (threadpoolctl), as in
:mod:`euc_sim.simulation.mujoco_batch`, so that no BLAS pool spins against the rides.
Where numba cannot compile, :func:`simulate_3d` runs its Python loop on each thread:
still exact, no faster than one thread (the GIL).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Callable, Mapping, Sequence


from euc_sim.simulation.errors import FallError, SimulationError
from euc_sim.stats import one_blas_thread

__all__ = ["ride_3d_many"]


def ride_3d_many(requests: Sequence[Mapping], *, nthread: int = 2, ride: Callable | None = None,
                 progress: Callable[[int], None] | None = None) -> list:
    """Ride every request on ``nthread`` threads; per request its result or its fall.

    Parameters
    ----------
    requests : sequence of mapping
        Keyword arguments of ``ride``, one mapping a ride (``path``, ``duration`` (s),
        ``seed``, ``speed`` (m/s), ...).
    nthread : int
        Threads (1: one after the other in the calling thread).
    ride : callable, optional
        :func:`euc_sim.simulation.spatial.simulate_3d` (default) or
        :func:`euc_sim.simulation.spatial.write_spatial` (then each request also names
        ``out``, and the results are the written paths).
    progress : callable, optional
        ``progress(done)`` in the calling thread as rides end (``done``: how many so far).

    Returns
    -------
    list
        In request order: what ``ride`` returns (the DataFrame of :func:`simulate_3d`),
        or the :class:`~euc_sim.simulation.errors.FallError` of a ride whose rider fell
        (returned, not raised).

    Raises
    ------
    SimulationError
        for a bad ``nthread``, or the first request's own bad input (a path, a duration).
    """
    from euc_sim.simulation import native_core
    from euc_sim.simulation.spatial import simulate_3d

    if not (isinstance(nthread, int) and not isinstance(nthread, bool) and nthread >= 1):
        raise SimulationError(f"ride_3d_many: nthread must be a positive integer, got {nthread!r}")
    ride = ride or simulate_3d
    requests = [dict(r) for r in requests]

    def one(kwargs: dict):
        try:
            return ride(**kwargs)
        except FallError as exc:
            return exc

    results: list = [None] * len(requests)
    if nthread == 1 or len(requests) <= 1:
        for i, r in enumerate(requests):
            results[i] = one(r)
            if progress:
                progress(i + 1)
        return results
    native_core.available()            # build the callback once, before the threads (one line if it cannot)
    with one_blas_thread(), ThreadPoolExecutor(nthread) as pool:
        futures = [pool.submit(one, r) for r in requests]
        for i, f in enumerate(futures):                # in order: a bad request raises here, the rest finish
            results[i] = f.result()
            if progress:
                progress(i + 1)
    return results
