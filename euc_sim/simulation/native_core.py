"""The machinery the native MuJoCo loops share: one control callback, a registry of runs.

MuJoCo's ``mjcb_control`` is one process-wide pointer.  The callback (compiled in
:mod:`euc_sim.simulation.native_kernels`) is installed while a native run is active and
serves every registered ``MjData`` from its own context (:class:`Context`, slots of
:mod:`native_layout`): runs on any threads never share state; an unregistered
``MjData`` is left alone.  Struct fields are reached through offsets found at run time
(:func:`field_offsets`, :func:`model_offsets`).  Where numba cannot compile,
:func:`callback` returns ``None`` after one line on stderr and the Python loops run.
"""

from __future__ import annotations

import os
import sys
import threading
from contextlib import contextmanager
from typing import Sequence

import numpy as np

from euc_sim.simulation.native_layout import (C_CALLS, C_FALL, C_FLOATS, C_KIND, C_NACT, C_PER, C_ROWS,
                                              C_SIZE, F_SIZE, KIND_COUNT, R_DU, R_FLOATS, R_GREF, R_INTEGRAL,
                                              R_KHIST, R_N, R_NOISE, R_PREF, R_UREF, R_VREF, C_ACT)

__all__ = ["field_offsets", "model_offsets", "callback", "available", "Context", "registered", "exclusive", "calls_per_step",
           "SLOTS"]

SLOTS = 64                                         # simulations served at once

_REGISTRY = np.zeros(2 * SLOTS, dtype=np.int64)    # (MjData address, context address); 0: free
_LOCK = threading.Lock()
_IDLE = threading.Condition(_LOCK)      # notified when the last registered run ends
_STATE = {"callback": None, "reason": "", "active": 0, "previous": None}


class Context:
    """One run's context: the int64 slots, the float slots and the arrays they point at."""

    def __init__(self, kind: int, rows: int, calls_per_step: int = 1):
        self.c = np.zeros(C_SIZE, dtype=np.int64)
        self.f = np.zeros(F_SIZE, dtype=np.float64)
        self._keep = [self.f]
        self._rider_floats: dict[int, np.ndarray] = {}
        self.c[[C_KIND, C_PER, C_ROWS, C_FALL, C_FLOATS]] = kind, calls_per_step, rows, -1, self.f.ctypes.data

    def put(self, slot: int, array: np.ndarray) -> np.ndarray:
        """Point int slot ``slot`` at ``array`` (C-contiguous float64, kept alive here)."""
        if array.dtype != np.float64 or not array.flags.c_contiguous:
            raise TypeError(f"context arrays must be C-contiguous float64, got {array.dtype} "
                            f"contiguous={array.flags.c_contiguous}")
        self._keep.append(array)
        self.c[slot] = array.ctypes.data
        return array

    def actuators(self, *ids: int) -> None:
        """The actuators whose controls the callback holds, in the order of ``F_HELD``."""
        self.c[C_NACT] = len(ids)
        self.c[C_ACT:C_ACT + len(ids)] = ids

    def rider(self, first: int, run) -> None:
        """The rider block at slot ``first`` from a :class:`~euc_sim.controllers.rider.RiderRun`
        (its own ``du`` buffer; z in the block's floats, :meth:`rider_z`).
        """
        for off, arr in ((R_VREF, run.v_ref), (R_GREF, run.gamma_ref), (R_PREF, run.phi_ref),
                         (R_UREF, run.u_ref), (R_NOISE, run.noise), (R_DU, run.du), (R_KHIST, run.k_hist)):
            self.put(first + off, np.ascontiguousarray(arr, dtype=np.float64))
        rf = np.zeros(9)
        rf[0], rf[1], rf[2] = run.dt, run.limit, run.z
        rf[3:3 + len(run.k_pred)] = run.k_pred
        self._rider_floats[first] = self.put(first + R_FLOATS, rf)
        self.c[first + R_INTEGRAL], self.c[first + R_N] = int(run.integral), run.n

    def rider_z(self, first: int) -> float:
        """The rider's integrator z now, m."""
        return float(self._rider_floats[first][2])

    @property
    def address(self) -> int:
        return int(self.c.ctypes.data)


def field_offsets(names: Sequence[str] = ("qpos", "qvel", "ctrl")) -> dict[str, int]:
    """Byte offsets in ``mjData`` of the array pointers ``names``, found on two live MjData
    (with ``nuserdata`` > 0) that must agree.
    """
    return _offsets(names, data=True)


def model_offsets(names: Sequence[str] = ("body_ipos", "site_pos")) -> dict[str, int]:
    """Byte offsets in ``mjModel`` of the array pointers ``names``, as :func:`field_offsets`."""
    return _offsets(names, data=False)


def _offsets(names: Sequence[str], data: bool) -> dict[str, int]:
    """:func:`field_offsets` (``data``) or :func:`model_offsets`."""
    import mujoco

    found = []
    for xml in ('<mujoco><size nuserdata="3"/><worldbody><body><joint name="a"/><geom size=".1"/>'
                '<site pos="0 0 .1"/></body></worldbody><actuator><motor joint="a"/></actuator></mujoco>',
                '<mujoco><size nuserdata="5"/><worldbody><body><joint name="a" type="slide"/><geom size=".1"/>'
                '<body><joint/><geom size=".1"/><site/><site pos=".1 0 0"/></body></body></worldbody>'
                '<actuator><motor joint="a"/></actuator></mujoco>'):
        m = mujoco.MjModel.from_xml_string(xml)
        obj = mujoco.MjData(m) if data else m
        targets = {name: getattr(obj, name).ctypes.data for name in names}
        found.append(_find_pointers(int(obj._address), targets, "mjData" if data else "mjModel"))
    if found[0] != found[1]:
        raise RuntimeError(f"{'mjData' if data else 'mjModel'} field offsets disagree between two models: {found}")
    return found[0]


#: The largest struct prefix searched for the pointers, bytes.
_SCAN_LIMIT = 8 << 20


def _find_pointers(base: int, targets: dict[str, int], what: str) -> dict[str, int]:
    """Byte offset from ``base`` of the first 8-byte word equal to each target address.

    Read through ``/proc/self/mem`` a page at a time, never by dereferencing: the search may
    run past the struct's end, where the next page may be unmapped (docs/robustness.md).
    ``RuntimeError`` where that file cannot be read or a pointer is not found.
    """

    try:
        fd = os.open("/proc/self/mem", os.O_RDONLY)
    except OSError as exc:
        raise RuntimeError(f"cannot read {what} safely to find its field offsets ({exc})") from None
    offs: dict[str, int] = {}
    try:
        pos, page = base, 4096
        while len(offs) < len(targets) and pos - base < _SCAN_LIMIT:
            want = page - pos % page
            try:
                chunk = os.pread(fd, want, pos)
            except OSError:               # the next page is not mapped: the struct ended before it
                break
            if len(chunk) < 8 or (pos - base) % 8:
                break
            w = np.frombuffer(chunk[:len(chunk) // 8 * 8], dtype=np.int64)
            for name, addr in targets.items():
                hit = np.flatnonzero(w == addr)
                if name not in offs and hit.size:
                    offs[name] = pos - base + int(hit[0]) * 8
            pos += len(chunk)
    finally:
        os.close(fd)
    if len(offs) < len(targets):
        raise RuntimeError(f"{what} pointers {sorted(set(targets) - set(offs))} not found in its first "
                           f"{pos - base} readable bytes")
    return offs


def callback():
    """The compiled control callback (built once per process), or ``None`` after one line on stderr."""
    if _STATE["callback"] is None:
        try:
            _STATE["callback"] = _compile()
        except Exception as exc:  # noqa: BLE001 - any failure means: use the Python loop
            _STATE["callback"], _STATE["reason"] = False, f"{type(exc).__name__}: {exc}".splitlines()[0]
    if not _STATE["callback"]:
        print(f"euc-sim: native closed loop unavailable ({_STATE['reason']}); using the Python loop",
              file=sys.stderr)
        return None
    return _STATE["callback"]


def available() -> bool:
    """Whether the native callback compiles here (compiles it on first call)."""
    if _STATE["callback"] is None:
        callback()
    return bool(_STATE["callback"])


def _compile():
    """numba ``cfunc`` of the kernels with MuJoCo's control-callback signature."""
    from euc_sim.simulation.native_kernels import build_callback  # deferred: loads numba (0.3 s)

    offs = field_offsets(("qpos", "qvel", "ctrl", "qfrc_applied", "xfrc_applied"))
    offs.update(model_offsets(("body_ipos", "site_pos")))
    return build_callback(offs["qpos"] // 8, offs["qvel"] // 8, offs["ctrl"] // 8, offs["qfrc_applied"] // 8,
                          offs["xfrc_applied"] // 8, offs["body_ipos"] // 8, offs["site_pos"] // 8,
                          int(_REGISTRY.ctypes.data), SLOTS)


@contextmanager
def registered(data, context: Context):
    """Serve ``data`` (an ``MjData``) with ``context`` inside the block, installing the callback for
    the first active run; ``RuntimeError`` if it cannot be built or all :data:`SLOTS` are taken.
    """
    import mujoco

    cb = _STATE["callback"] or callback()
    if not cb:
        raise RuntimeError(f"the native control callback is unavailable ({_STATE['reason']})")
    with _LOCK:
        free = np.flatnonzero(_REGISTRY[0::2] == 0)
        if not free.size:
            raise RuntimeError(f"all {SLOTS} native simulation slots are taken")
        s = int(free[0])
        _REGISTRY[2 * s + 1] = context.address        # the context first, then the key
        _REGISTRY[2 * s] = int(data._address)
        if _STATE["active"] == 0:
            _STATE["previous"] = mujoco.get_mjcb_control()
            mujoco.set_mjcb_control(cb.ctypes)
        _STATE["active"] += 1
    try:
        yield s
    finally:
        with _LOCK:
            _REGISTRY[2 * s] = 0
            _REGISTRY[2 * s + 1] = 0
            _STATE["active"] -= 1
            if _STATE["active"] == 0:
                mujoco.set_mjcb_control(_STATE["previous"])
                _STATE["previous"] = None
                _IDLE.notify_all()


#: Steps run in C between two looks for a fall (a fallen run goes on at most this far).
CHUNK_STEPS = 100


def ride(m, d, context: Context, steps: int, chunk: int = CHUNK_STEPS, progress=None) -> None:
    """Step ``d`` ``steps`` times with ``context`` served, ``chunk`` steps at a time, until the callback
    flags a fall; then once more (``mj_forward``) for the last row.  ``progress(k)`` before each block.
    """
    import mujoco

    context.c[C_PER] = calls_per_step(m, d)
    with registered(d, context):
        for k0 in range(0, steps + 1, chunk):
            if progress is not None:
                progress(k0)
            if steps > k0:
                mujoco.mj_step(m, d, nstep=min(chunk, steps - k0))
            if context.c[C_FALL] >= 0:
                return
        context.c[C_CALLS] = 0
        mujoco.mj_forward(m, d)


@contextmanager
def exclusive(cb):
    """Install ``cb`` (a callback of another layout, :mod:`mujoco_batch`) alone for the block: waits for
    the registered runs to end and holds new ones back.
    """
    import mujoco

    with _IDLE:
        _IDLE.wait_for(lambda: _STATE["active"] == 0)
        previous = mujoco.get_mjcb_control()
        mujoco.set_mjcb_control(cb.ctypes)
        try:
            yield
        finally:
            mujoco.set_mjcb_control(previous)


_CALLS_PER_STEP: dict = {}


def calls_per_step(m, d) -> int:
    """Callback calls per ``mj_step`` (4 for RK4), counted once per integrator and disable flags
    on a copy of ``d`` (the callback built).
    """
    key = (int(m.opt.integrator), int(m.opt.disableflags))
    if key not in _CALLS_PER_STEP:
        _CALLS_PER_STEP[key] = _count_calls(m, d)
    return _CALLS_PER_STEP[key]


def _count_calls(m, d) -> int:
    """Callback calls of one ``mj_step`` of a copy of ``d``."""
    import mujoco

    probe = mujoco.MjData(m)
    mujoco.mj_copyData(probe, m, d)
    ctx = Context(KIND_COUNT, 0)
    with registered(probe, ctx):
        mujoco.mj_step(m, probe)
    calls = int(ctx.c[C_CALLS])
    if calls < 1:
        raise RuntimeError("the control callback was not called by mj_step")
    return calls
