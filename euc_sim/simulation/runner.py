"""Run many named tasks (rides, recordings, diagnoses) serially, in a process pool or on Dask.

:func:`run_tasks` calls ``fn(arg)`` for every named task and returns a :class:`RunReport`.
Backends: in this process (``workers=1``), a process pool of N (workers ignore Ctrl-C and
die with their parent), a local Dask cluster (``scheduler="local"``, TLS, reachable by
this process only) or a running Dask scheduler (trusted with code: tasks and results
travel pickled).  A task that raises, or whose worker dies, fails alone, by name.
Ctrl-C and SIGTERM stop the workers before re-raising; results reach ``on_result`` in
the parent as they arrive; a task's result depends on its argument only.  See
docs/scale.md.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

from tqdm import tqdm

from euc_sim.errors import InputError

__all__ = ["RunReport", "run_tasks", "check_backend"]


@dataclass
class RunReport:
    """The outcome of :func:`run_tasks`.

    Attributes
    ----------
    names : list of str
        Every task, in the order given.
    results : dict
        ``{name: fn(arg)}`` of the tasks that succeeded.
    failed : dict
        ``{name: reason}`` (one line) of the tasks that failed.
    backend : str
        ``serial``, ``pool of N`` or ``dask <address>``.
    seconds : float
        Wall time, s.
    """

    names: list
    results: dict = field(default_factory=dict)
    failed: dict = field(default_factory=dict)
    backend: str = "serial"
    seconds: float = 0.0

    def ordered(self) -> list:
        """Results of the successful tasks, in task order."""
        return [self.results[n] for n in self.names if n in self.results]

    def table(self) -> str:
        """A plain-text summary: counts, time, and every failed task by name."""
        lines = [f"{'tasks':<10}{len(self.names):>8}",
                 f"{'finished':<10}{len(self.results):>8}",
                 f"{'failed':<10}{len(self.failed):>8}",
                 f"{'backend':<10}{self.backend:>8}",
                 f"{'wall time':<10}{self.seconds:>7.1f}s"]
        if self.failed:
            width = max(len(n) for n in self.failed)
            lines.append("failed tasks:")
            lines += [f"  {n:<{width}}  {self.failed[n]}" for n in self.names if n in self.failed]
        return "\n".join(lines)


def check_backend(scheduler: str | None, workers: int | None) -> None:
    """Raise ``ValueError`` naming the option for an unusable ``--scheduler``/``--workers``."""
    if workers is not None and (not isinstance(workers, int) or isinstance(workers, bool) or workers < 1):
        raise InputError(f"--workers must be a positive integer, got {workers!r}")
    if scheduler is None or scheduler == "local":
        return
    if not _is_address(scheduler):
        raise InputError(f"--scheduler must be 'local' or a Dask scheduler address tcp://HOST:PORT "
                         f"(or tls://HOST:PORT), got {scheduler!r}")


def _is_address(text) -> bool:
    """Whether ``text`` is ``[tcp://|tls://]HOST:PORT`` with a port in 1-65535."""
    if not isinstance(text, str):
        return False
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    host, colon, port = rest.rpartition(":")
    host = host[1:-1] if host.startswith("[") and host.endswith("]") else host      # [IPv6]
    return (scheme in ("tcp", "tls") and bool(colon) and bool(host) and "/" not in host
            and port.isdigit() and 1 <= int(port) <= 65535)


def _reason(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}".rstrip(": ")


def _guarded(fn: Callable, arg) -> tuple[bool, Any]:
    """``(True, fn(arg))`` or ``(False, reason)``: exceptions cross process bounds as text."""
    try:
        return True, fn(arg)
    except Exception as exc:           # a fall or any other failure of this task alone
        return False, _reason(exc)


def worker_init(parent: int) -> None:
    """Pool worker: ignore Ctrl-C, default SIGTERM, and die with the parent (Linux ``PR_SET_PDEATHSIG``).

    Pass as ``ProcessPoolExecutor(initializer=worker_init, initargs=(os.getpid(),))``.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux"):
        PR_SET_PDEATHSIG = 1
        try:
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
        except (OSError, AttributeError):       # pragma: no cover - no prctl
            pass
    if os.getppid() != parent:                   # the parent died before prctl took effect
        os._exit(1)


def _sigterm_as_interrupt():
    """Make SIGTERM raise KeyboardInterrupt (main thread only); returns the old handler."""
    if threading.current_thread() is not threading.main_thread():
        return None

    def handler(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")
    return signal.signal(signal.SIGTERM, handler)


def run_tasks(fn: Callable, tasks: Sequence[tuple[str, Any]], *, scheduler: str | None = None,
              workers: int | None = None, progress: bool = True, desc: str = "tasks",
              on_result: Callable[[str, Any], None] | None = None) -> RunReport:
    """Run ``fn(arg)`` for every ``(name, arg)`` in ``tasks`` (unique names).

    Parameters
    ----------
    fn : callable
        A module-level (picklable) function of one argument.
    tasks : sequence of (str, object)
    scheduler : {None, "local"} or str
        None: this machine; ``"local"``: a local Dask cluster; else a Dask scheduler's address.
    workers : int, optional
        Pool processes (default: all cores; 1 runs in this process) or local Dask workers (default 2).
    progress : bool
        A progress bar on stderr, labelled ``desc``.
    on_result : callable, optional
        ``on_result(name, value)`` in this process for each success, as it arrives.
    """
    check_backend(scheduler, workers)
    names = [n for n, _ in tasks]
    if len(set(names)) != len(names):
        raise ValueError("run_tasks: task names must be unique")
    report = RunReport(names=names)
    bar = tqdm(total=len(tasks), desc=desc, unit="task", disable=not progress, file=sys.stderr)

    def done(name: str, ok: bool, value) -> None:
        if ok:
            report.results[name] = value
            if on_result is not None:
                on_result(name, value)
        else:
            report.failed[name] = value
        bar.update()
        if report.failed:
            bar.set_postfix(failed=len(report.failed))

    t0 = time.perf_counter()
    old = _sigterm_as_interrupt()
    try:
        if scheduler is not None:
            report.backend = _run_dask(fn, tasks, scheduler, workers, done)
        elif (workers or os.cpu_count() or 1) == 1 or len(tasks) <= 1:
            report.backend = "serial"
            for name, arg in tasks:
                done(name, *_guarded(fn, arg))
        else:
            n = workers or os.cpu_count() or 1
            report.backend = f"pool of {n}"
            _run_pool(fn, tasks, n, done)
    finally:
        bar.close()
        if old is not None:
            signal.signal(signal.SIGTERM, old)
        report.seconds = time.perf_counter() - t0
        report.results = {n: report.results[n] for n in names if n in report.results}
        report.failed = {n: report.failed[n] for n in names if n in report.failed}
    return report


def _kill(pool: ProcessPoolExecutor) -> None:
    terminate = getattr(pool, "terminate_workers", None)          # Python >= 3.14
    if terminate is not None:
        terminate()
    else:
        for proc in list((getattr(pool, "_processes", None) or {}).values()):
            proc.kill()
    pool.shutdown(wait=False, cancel_futures=True)


def _pool_round(fn, tasks, workers: int, done) -> list:
    """Run ``tasks`` in one pool; returns those whose worker died (pool broken)."""
    broken = []
    pool = ProcessPoolExecutor(workers, initializer=worker_init, initargs=(os.getpid(),))
    try:
        futures = {pool.submit(_guarded, fn, arg): (name, arg) for name, arg in tasks}
        for fut in as_completed(futures):
            name, arg = futures[fut]
            try:
                ok, value = fut.result()
            except BrokenProcessPool:
                broken.append((name, arg))
                continue
            done(name, ok, value)
    except BaseException:
        _kill(pool)
        raise
    pool.shutdown(wait=True)
    return broken


def _run_pool(fn, tasks, workers: int, done) -> None:
    broken = _pool_round(fn, tasks, workers, done)
    for name, arg in broken:                 # one at a time: the task that kills its worker
        if _pool_round(fn, [(name, arg)], 1, done):
            done(name, False, "worker died (its process ended without a result)")


def _run_dask(fn, tasks, scheduler: str, workers: int | None, done) -> str:
    from distributed import Client, as_completed as dask_completed
    from distributed.scheduler import KilledWorker

    from euc_sim.simulation.dask_backend import CONNECT_TIMEOUT, check_scheduler, local_cluster  # deferred: loads distributed (0.3 s)

    cluster = None
    scratch = contextlib.ExitStack()           # a local cluster's dask-scratch-space, removed after
    if scheduler == "local":
        try:
            cluster, client = local_cluster(workers or 2, scratch)
        except BaseException:
            scratch.close()
            raise
        backend = f"dask local, {workers or 2} workers"
    else:
        check_scheduler(scheduler, CONNECT_TIMEOUT)
        client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        backend = f"dask {scheduler}"
    futures = []
    try:
        futures = [client.submit(_guarded, fn, arg, key=f"{name}-{i}-{os.getpid()}-{time.time_ns()}",
                                 pure=False) for i, (name, arg) in enumerate(tasks)]
        by_key = {f.key: name for f, (name, _) in zip(futures, tasks)}
        for fut in dask_completed(futures):
            name = by_key[fut.key]
            try:
                ok, value = fut.result()
            except KilledWorker:
                ok, value = False, "worker died (KilledWorker: Dask gave up after retries)"
            except Exception as exc:        # the task could not run or its result not return
                ok, value = False, _reason(exc)
            done(name, ok, value)
            fut.release()
    finally:
        if futures:
            client.cancel(futures)
        client.close()
        if cluster is not None:
            cluster.close()
        scratch.close()
    return backend
