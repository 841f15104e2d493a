"""``euc-sim dataset`` on every backend: the same bytes, a private local Dask cluster, a folder
that appears whole or not at all, and a refusal for a folder holding something else."""

from __future__ import annotations

import hashlib
import json
import mmap
import ssl
import socket
import sys
from pathlib import Path

import numpy as np
import pytest

from euc_sim.cli import main

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")


def _digests(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def _leftovers(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.name.startswith(".")]


def _dataset(out: Path, *extra: str) -> int:
    return main(["dataset", "--out-dir", str(out), "--seed", "3", "--duration", "1", "--quiet", *extra])


def test_dataset_same_bytes_serial_pool_and_local_dask_twice(tmp_path, capsys):
    """Every task finishes on the process pool and on two local Dask clusters in a row, and
    every file is the serial run's, byte for byte (the batches do not depend on the backend)."""
    assert _dataset(tmp_path / "serial", "--workers", "1") == 0
    ref = _digests(tmp_path / "serial")
    assert len(ref) == 14 * 3 + 1
    runs = [("pool", ("--workers", "2")), ("dask1", ("--scheduler", "local")), ("dask2", ("--scheduler", "local"))]
    for name, opts in runs:
        capsys.readouterr()
        assert _dataset(tmp_path / name, *opts) == 0, name
        err = capsys.readouterr().err
        assert "wrote 14 of 14 recordings" in err and "KilledWorker" not in err, err
        assert _digests(tmp_path / name) == ref, name
    assert not _leftovers(tmp_path)


def _listening(pids: set[int]) -> set[tuple[str, int]]:
    """(ip, port) of the TCP sockets in LISTEN state that the processes ``pids`` own."""
    import psutil

    out = set()
    for pid in pids:
        for c in psutil.Process(pid).net_connections(kind="tcp"):
            if c.status == psutil.CONN_LISTEN:
                out.add((c.laddr.ip, c.laddr.port))
    return out


def _plain_tls_refused(ip: str, port: int) -> bool:
    """Whether a TLS handshake without a client certificate fails (or no TLS is spoken)."""
    ctx = ssl.create_default_context()
    ctx.check_hostname, ctx.verify_mode = False, ssl.CERT_NONE
    try:
        with socket.create_connection((ip, port), timeout=5) as raw, ctx.wrap_socket(raw) as tls:
            tls.sendall(b"GET / HTTP/1.0\r\n\r\n")
            return not tls.recv(64)
    except (ssl.SSLError, OSError):
        return True


def _hostname(_):
    return socket.gethostname()


def _speaks_http(ip: str, port: int) -> bool:
    """Whether a plain ``GET / HTTP/1.0`` gets an HTTP answer."""
    try:
        with socket.create_connection((ip, port), timeout=2) as s:
            s.sendall(b"GET / HTTP/1.0\r\n\r\n")
            return s.recv(16).startswith(b"HTTP/")
    except OSError:
        return False


@linux
def test_local_cluster_listens_on_tls_only_without_http(tmp_path):
    """From the moment ``--scheduler local`` starts until it ends, every listening port of the
    command and its workers is on 127.0.0.1, speaks no HTTP (not even for a moment) and refuses
    a TLS client without the cluster's certificate."""
    import threading

    import psutil

    from euc_sim.simulation.runner import run_tasks

    me = psutil.Process()
    probed: dict[tuple[str, int], bool] = {}
    seen: list[set] = []
    stop = threading.Event()

    def pids():
        return {me.pid} | {p.pid for p in me.children(recursive=True)}

    def watch():                          # every new listening port, as soon as it opens
        while not stop.is_set():
            try:
                ports = _listening(pids())
            except psutil.Error:          # a process ended while being looked at
                continue
            for addr in ports - probed.keys():
                probed[addr] = _speaks_http(*addr)
            stop.wait(0.02)

    def check(name, value):
        ports = _listening(pids())
        seen.append(ports)
        assert all(_plain_tls_refused(ip, port) for ip, port in ports), ports

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    try:
        rep = run_tasks(_hostname, [("a", 0), ("b", 1)], scheduler="local", progress=False, on_result=check)
    finally:
        stop.set()
        watcher.join()
    assert not rep.failed and len(seen) == 2
    assert len(seen[0]) == 5            # the scheduler, two nannies and two workers: their comms only
    assert probed and all(ip == "127.0.0.1" for ip, _ in probed), probed
    assert not [addr for addr, http in probed.items() if http], probed


class _NotAScheduler:
    """A TCP server on 127.0.0.1 that greets every connection with ``mode``: ``garbage`` (an
    HTTP answer, whose first 8 bytes read as a length of 3.07 EiB), ``silent`` (never a
    byte) or ``close`` (hangs up at once)."""

    def __init__(self, mode: str):
        import threading

        self.mode, self.held = mode, []
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.address = f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            if self.mode == "garbage":
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" + bytes(4096))
            if self.mode == "close":
                conn.close()
            else:
                self.held.append(conn)

    def close(self):
        self.sock.close()
        for conn in self.held:
            conn.close()


@pytest.mark.parametrize("mode", ["garbage", "silent", "close"])
def test_a_server_that_is_no_scheduler_is_refused_in_one_line(tmp_path, capsys, monkeypatch, mode):
    """``--scheduler`` at something that is not a Dask scheduler: exit 2 and one line naming the
    address, within the connect timeout (handshake included) + 5 s, and no folder."""
    import threading

    from euc_sim.simulation import dask_backend

    timeout = 3.0
    monkeypatch.setattr(dask_backend, "CONNECT_TIMEOUT", timeout)
    server = _NotAScheduler(mode)
    codes = []
    run = threading.Thread(target=lambda: codes.append(_dataset(tmp_path / "d", "--scheduler", server.address)),
                           daemon=True)
    try:
        run.start()
        run.join(timeout + 5)
    finally:
        server.close()
    assert codes == [2], f"{mode}: {codes or 'still running'} after {timeout + 5} s"
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and server.address in err and "not a Dask scheduler" in err, err
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize("value", ["a:b", "tcp://host:99999", "http://host:8786", "local2", "tcp://:8786"])
def test_bad_scheduler_is_one_line_exit_2(tmp_path, capsys, value):
    assert _dataset(tmp_path / "d", "--scheduler", value) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--scheduler" in err and repr(value) in err, err
    assert not list(tmp_path.iterdir())


@linux
def test_pointer_search_stops_at_an_unmapped_page():
    """The field-offset search reads memory through /proc/self/mem: past a struct's last
    readable page it stops (it read past the mapping, and faulted, in Dask's worker threads)."""
    import ctypes

    from euc_sim.simulation.native_core import _find_pointers

    page = mmap.PAGESIZE
    libc = ctypes.CDLL(None, use_errno=True)
    libc.mmap.restype = ctypes.c_void_p
    libc.mmap.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_long)
    libc.munmap.argtypes = (ctypes.c_void_p, ctypes.c_size_t)
    base = libc.mmap(None, 2 * page, 3, 0x22, -1, 0)           # PROT_READ|WRITE, MAP_PRIVATE|ANONYMOUS
    assert base not in (None, ctypes.c_void_p(-1).value)
    assert libc.munmap(base + page, page) == 0                 # the second page: not mapped
    try:
        ctypes.c_int64.from_address(base + 800).value = 0x1234_5678_9ABC
        assert _find_pointers(base, {"a": 0x1234_5678_9ABC}, "test") == {"a": 800}
        with pytest.raises(RuntimeError, match=f"not found in its first {page} readable bytes"):
            _find_pointers(base, {"a": 0x1234_5678_9ABC, "b": 77}, "test")
    finally:
        libc.munmap(base, page)


def _small_plan(seed=5):
    from euc_sim.simulation.dataset import dataset_plan
    return dataset_plan(seed=seed, duration=1.0, counts=(("constant_speed", 3), ("deceleration", 2)))


def test_interrupted_dataset_leaves_nothing_and_the_previous_one_whole(tmp_path, monkeypatch):
    """Ctrl-C after some recordings were written: no folder appears; over a previous dataset
    of the same plan, that one is left byte for byte."""
    from euc_sim.simulation import dataset

    real = dataset.io.write_recording
    calls = {"n": 0}

    def write_then_interrupted(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    out = tmp_path / "new" / "d"
    monkeypatch.setattr(dataset.io, "write_recording", write_then_interrupted)
    with pytest.raises(KeyboardInterrupt):
        dataset.run_dataset(out, _small_plan(), workers=1, progress=False, batch=2)
    assert list(tmp_path.iterdir()) == []           # neither d nor the folder made for it

    monkeypatch.setattr(dataset.io, "write_recording", real)
    done = tmp_path / "done"
    dataset.run_dataset(done, _small_plan(), workers=1, progress=False, batch=2)
    before = _digests(done)
    calls["n"] = 0
    monkeypatch.setattr(dataset.io, "write_recording", write_then_interrupted)
    with pytest.raises(KeyboardInterrupt):
        dataset.run_dataset(done, _small_plan(), workers=1, progress=False, batch=2)
    assert _digests(done) == before and not _leftovers(tmp_path)


def test_dataset_folder_rules_and_manifest(tmp_path, capsys):
    """A rerun of the same settings replaces its dataset; other settings, or foreign files,
    are refused in one line with exit 2 and nothing touched; the manifest names the seed,
    the settings and the plan."""
    out = tmp_path / "d"
    assert _dataset(out, "--workers", "1") == 0
    manifest = json.loads((out / "dataset.json").read_text())
    assert manifest["seed"] == 3 and manifest["settings"]["duration"] == 1.0
    assert manifest["settings"]["noise"] == "paper" and len(manifest["plan"]) == 64
    first = _digests(out)
    assert _dataset(out, "--workers", "2") == 0 and _digests(out) == first    # same settings: replaced

    for argv in (("--seed", "4"), ("--duration", "2"), ("--noise", "none")):
        capsys.readouterr()
        assert main(["dataset", "--out-dir", str(out), "--seed", "3", "--duration", "1", "--quiet",
                     "--workers", "1", *argv]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and str(out) in err and "not a previous dataset" in err, err
        assert _digests(out) == first

    (out / "notes.txt").write_text("mine")
    assert _dataset(out, "--workers", "1") == 2              # same settings, but a foreign file
    assert (out / "notes.txt").read_text() == "mine"
    other = tmp_path / "other"
    other.mkdir()
    (other / "x.csv").write_text("t\n0\n")
    assert _dataset(other, "--workers", "1") == 2 and [p.name for p in other.iterdir()] == ["x.csv"]
    empty = tmp_path / "empty"
    empty.mkdir()
    assert _dataset(empty, "--workers", "1") == 0 and _digests(empty) == first
    assert not _leftovers(tmp_path)


def test_dataset_batches_do_not_depend_on_the_backend(tmp_path, monkeypatch):
    """The tasks (batches of recordings) are the same serial, on a pool of 2 or 3 and on Dask:
    the rider's batched sums round by the batch's make-up (8 s recordings of seed 3 differed
    in the last digit between one batch of 14 and two of 7)."""
    from euc_sim.simulation import dataset, runner

    seen = []

    def record(fn, tasks, **kwargs):
        seen.append([(name, [s.name for s in specs]) for name, (specs, _) in tasks])
        raise KeyboardInterrupt          # nothing needs to run

    monkeypatch.setattr(runner, "run_tasks", record)
    specs = dataset.dataset_plan(seed=3, duration=1.0)
    for i, backend in enumerate(({"workers": 1}, {"workers": 2}, {"workers": 3}, {"scheduler": "local"},
                                 {"scheduler": "local", "workers": 4})):
        with pytest.raises(KeyboardInterrupt):
            dataset.run_dataset(tmp_path / f"d{i}", specs, progress=False, **backend)
    assert len(seen) == 5 and all(tasks == seen[0] for tasks in seen)
    assert [len(names) for _, names in seen[0]] == [8, 6]
    assert not list(tmp_path.iterdir())
