"""The Dask side of :mod:`euc_sim.simulation.runner`: a private local cluster without HTTP
servers, and a check that a remote address is a Dask scheduler (imports ``distributed``).
"""

from __future__ import annotations

import socket
import struct
import tempfile
import time

from distributed import Client, LocalCluster, Nanny, Scheduler, Worker
from distributed.comm import parse_address, parse_host_port
from distributed.protocol.core import loads
from distributed.protocol.utils import unpack_frames

from euc_sim.errors import InputError

__all__ = ["local_cluster", "check_scheduler", "CONNECT_TIMEOUT"]

#: How long a remote scheduler has to connect and say its handshake, s.
CONNECT_TIMEOUT = 30.0
#: The largest first message a Dask node's handshake can be, bytes (it is about 100).
_MAX_HANDSHAKE = 1 << 16


class _NoHttp:
    """A Dask node that serves no HTTP (distributed starts one on every node and it answers anyone)."""

    def start_http_server(self, *args, **kwargs) -> None:
        return None


class _Scheduler(_NoHttp, Scheduler):
    pass


class _Worker(_NoHttp, Worker):
    pass


class _Nanny(Nanny):
    """A nanny whose worker process runs :class:`_Worker`."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, worker_class=_Worker, **kwargs)


class _Cluster(LocalCluster):
    """A :class:`distributed.LocalCluster` whose scheduler is :class:`_Scheduler`."""

    async def _start(self):
        self.scheduler_spec = {**self.scheduler_spec, "cls": _Scheduler}
        await super()._start()


def local_cluster(workers: int, scratch):
    """A local cluster of ``workers`` single-threaded processes only this process can use, and its client.

    TLS on 127.0.0.1 with throwaway credentials and client certificates required; no HTTP
    port.  ``scratch`` (an ``ExitStack``) gets the temporary folder and configuration.
    """
    import dask

    tmp = scratch.enter_context(tempfile.TemporaryDirectory(prefix="euc-sim-dask-"))
    scratch.enter_context(dask.config.set({"temporary-directory": tmp}))
    cluster = _Cluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                       security=True, dashboard_address=None, worker_class=_Nanny, local_directory=tmp)
    try:
        client = Client(cluster)
    except BaseException:
        cluster.close()
        raise
    return cluster, client


def check_scheduler(address: str, timeout: float) -> None:
    """``InputError`` naming ``--scheduler`` unless a ``tcp://`` address sends a Dask handshake of at
    most ``_MAX_HANDSHAKE`` bytes within ``timeout`` s (distributed's client would wait forever
    and allocate what the peer announces); ``tls://`` is left to the client.
    """
    scheme, loc = parse_address(address)
    if scheme != "tcp":
        return
    deadline = time.monotonic() + timeout
    try:
        host, port = parse_host_port(loc)
        with socket.create_connection((host, port), timeout=timeout) as sock:
            (size,) = struct.unpack("Q", _receive(sock, 8, deadline))
            if not 16 <= size <= _MAX_HANDSHAKE:
                why = f"its first message announces {size} bytes"
            else:
                why = _not_a_handshake(_receive(sock, size, deadline))
    except TimeoutError:
        why = f"no handshake within {timeout:g} s"
    except (OSError, ValueError) as exc:
        why = getattr(exc, "strerror", None) or str(exc)
    if why:
        raise InputError(f"--scheduler {address}: not a Dask scheduler ({why})")


def _receive(sock: socket.socket, n: int, deadline: float) -> bytes:
    """Exactly ``n`` bytes from ``sock`` before ``deadline`` (``time.monotonic``)."""
    out = bytearray()
    while len(out) < n:
        sock.settimeout(max(deadline - time.monotonic(), 1e-3))
        chunk = sock.recv(n - len(out))
        if not chunk:
            raise ValueError(f"it closed the connection after {len(out)} bytes")
        out += chunk
    return bytes(out)


def _not_a_handshake(body: bytes) -> str | None:
    """Why ``body`` is not a Dask handshake message (None: it is)."""
    (count,) = struct.unpack_from("Q", body)
    try:
        if 8 * (count + 1) > len(body):
            raise ValueError
        msg = loads(unpack_frames(body), deserialize=False)
    except Exception:  # noqa: BLE001 - any garbage
        return "its first message is not a Dask handshake"
    return None if isinstance(msg, dict) and "compression" in msg else "its first message is not a Dask handshake"
