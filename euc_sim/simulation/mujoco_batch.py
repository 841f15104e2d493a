"""MuJoCo rides in batches on threads: ``mujoco.batch.Batch`` with the catalog's effects.

:func:`simulate_rides` runs many :func:`euc_sim.simulation.engine.simulate` requests as the
simulations of ``mujoco.batch.Batch`` objects and returns, per request, the DataFrame
``simulate`` returns or the ``FallError`` it raises.  Per step, a numba ``cfunc`` control
callback applies the motor PD, the held external forces (:func:`euc_sim.simulation.effects.held_forces`)
and the fall bounds, its context in each simulation's ``MjData.userdata``; per block of
n + 1 steps, the rider's delayed law runs in numpy across the batch.  Requests the batch
cannot carry (other effects, ``engine="analytic"``) run through ``simulate``.  Agrees with
``simulate`` to rounding.  See docs/mujoco_batch.md.
"""

from __future__ import annotations

import inspect
import queue
import sys
import threading
from functools import lru_cache
from typing import Callable, Mapping, Sequence

import mujoco
import mujoco.batch
import numpy as np
from scipy.linalg.lapack import dtrtrs

from euc_sim.controllers.motor import pd_torque
from euc_sim.model.mujoco_model import build_spec
from euc_sim.simulation import engine
from euc_sim.simulation.errors import FallError, UnstableError
from euc_sim.simulation.native_core import exclusive, field_offsets
from euc_sim.stats import one_blas_thread

__all__ = ["simulate_rides", "batchable", "available", "NU", "BATCH_EFFECTS", "PIPELINE_BATCHES"]

#: Effects the batch applies itself (the others of the catalog run through :func:`simulate`).
BATCH_EFFECTS = ("rolling_resistance", "aerodynamic_drag", "road_slope", "wheel_bearing_friction",
                 "rider_mass", "sensor_time_offset")
#: Batches per thread from which :func:`simulate_rides` pipelines (below, a lone thread's last
#: batch would cost more than the serial Python work the pipeline hides: about 1/10 of a ride).
PIPELINE_BATCHES = 3
#: ``MjData.userdata`` slots per simulation.
NU = 48
_MAGIC = 23.0625                       # slot S_MAGIC: this simulation is one of ours
(S_CALLS, S_PER, S_K, S_ROWS, S_STATE, S_MD, S_MH, S_FALL, S_IX, S_IG, S_IR, S_VX, S_VG, S_VR,
 S_AM, S_AA, S_BR, S_BW, S_SPIN, S_PHI, S_GAM, S_HMD, S_HMH, S_EFF, S_KDRAG, S_CRR, S_R,
 S_NLOAD, S_PUSH, S_MAGIC) = range(30)
S_LAW = 32                             # 32 … 42: MotorPD.law_args()
_SIM_KEYS = tuple(inspect.signature(engine.prepare).parameters)


def batchable(request: Mapping) -> bool:
    """Whether a :func:`simulate` request (its keyword arguments) runs in the batch."""
    eff = dict(request.get("effects") or {})
    return (request.get("engine", "mujoco") == "mujoco" and set(eff) <= set(BATCH_EFFECTS)
            and request.get("lateral_motion") is None and request.get("drift_shape") is None)


def available() -> bool:
    """Whether the batch's native callback compiles here (compiles it on first call)."""
    return _callback()[0] is not None


@lru_cache(maxsize=1)
def _callback() -> tuple:
    """(the batch's compiled callback, "") once per process, or (None, why it cannot be built)."""
    try:
        return _compile(), ""
    except Exception as exc:  # noqa: BLE001 - any failure means: simulate() one by one
        return None, f"{type(exc).__name__}: {exc}".splitlines()[0]


def _compile():
    """numba ``cfunc`` with MuJoCo's control-callback signature, context in ``d->userdata``."""
    from numba import carray, cfunc, njit, types

    from euc_sim.simulation.native_kernels import address, f64p, held_forces, i64p  # deferred: loads numba (0.3 s)

    offs = field_offsets(("userdata", "qpos", "qvel", "ctrl", "qfrc_applied", "xfrc_applied"))
    W_UD, W_QPOS, W_QVEL = offs["userdata"] // 8, offs["qpos"] // 8, offs["qvel"] // 8
    W_CTRL, W_QFRC, W_XFRC = offs["ctrl"] // 8, offs["qfrc_applied"] // 8, offs["xfrc_applied"] // 8

    law = njit(pd_torque)
    MAGIC = _MAGIC

    @cfunc(types.void(types.voidptr, types.voidptr))
    def control(m, d):
        dw = i64p(address(d))
        if dw[W_UD] == 0:
            return
        ud = carray(f64p(dw[W_UD]), NU)
        if ud[S_MAGIC] != MAGIC:                 # not a simulation of a batch (another loop's data)
            return
        calls = int(ud[S_CALLS])
        ud[S_CALLS] = calls + 1.0
        if calls % int(ud[S_PER]) == 0:          # the first call of a step: the state at its start
            k = int(ud[S_K])
            if k < int(ud[S_ROWS]):
                qpos, qvel = f64p(dw[W_QPOS]), f64p(dw[W_QVEL])
                g = qpos[int(ud[S_IG])]
                gd = qvel[int(ud[S_VG])]
                xd = qvel[int(ud[S_VX])]
                row = f64p(int(ud[S_STATE]) + 48 * k)
                row[0] = qpos[int(ud[S_IX])]
                row[1] = g
                row[2] = g + qpos[int(ud[S_IR])]
                row[3] = xd
                row[4] = gd
                row[5] = gd + qvel[int(ud[S_VR])]
                if ud[S_FALL] < 0.0:              # the first fall: a bound passed or a non-finite state
                    fine = abs(row[2]) <= ud[S_PHI] and abs(g) <= ud[S_GAM]
                    for j in range(6):
                        fine = fine and row[j] - row[j] == 0.0
                    if not fine:
                        ud[S_FALL] = k
                M_d = law(g, gd, xd, ud[S_LAW], ud[S_LAW + 1], ud[S_LAW + 2], ud[S_LAW + 3],
                          ud[S_LAW + 4], ud[S_LAW + 5], ud[S_LAW + 6], ud[S_LAW + 7], ud[S_LAW + 8],
                          ud[S_LAW + 9], ud[S_LAW + 10])
                f64p(int(ud[S_MD]))[k] = M_d
                ud[S_HMD] = M_d
                ud[S_HMH] = f64p(int(ud[S_MH]))[k]
                if ud[S_EFF] != 0.0:              # effects.held_forces: held over the step
                    push = int(ud[S_PUSH])
                    F, tau = held_forces(xd, ud[S_KDRAG], ud[S_CRR], ud[S_NLOAD], ud[S_R],
                                         f64p(push)[k] if push != 0 else 0.0)
                    xf = f64p(dw[W_XFRC])
                    xf[6 * int(ud[S_BR])] = F
                    if ud[S_SPIN] != 0.0:
                        xf[6 * int(ud[S_BW]) + 4] = tau
                    else:
                        f64p(dw[W_QFRC])[int(ud[S_VX])] = 0.0 + tau / ud[S_R]
                ud[S_K] = k + 1.0
        ctrl = f64p(dw[W_CTRL])
        ctrl[int(ud[S_AM])] = ud[S_HMD]
        ctrl[int(ud[S_AA])] = ud[S_HMH]

    return control


def simulate_rides(requests: Sequence[Mapping], *, nthread: int = 2, batch: int = 128,
                   progress: Callable[[int], None] | None = None) -> list:
    """Run many :func:`simulate` requests in MuJoCo batches on threads.

    Parameters
    ----------
    requests : sequence of mapping
        Keyword arguments of :func:`euc_sim.simulation.engine.simulate`, one mapping per ride.
    nthread : int
        Threads stepping the batches (0: MuJoCo's default pool).  From
        :data:`PIPELINE_BATCHES` × ``nthread`` batches on (``nthread`` ≥ 2) each thread steps
        batches of its own while the calling thread prepares the next (:func:`_pipeline`);
        otherwise the batches run one after the other on ``nthread`` threads.  Threads never
        change a ride.
    batch : int
        Rides per ``Batch`` at most; the batches' make-up (hence the rounding of the rider's
        batched sums) depends on it only.
    progress : callable, optional
        ``progress(n)`` with the number of rides finished, called in the calling thread.

    Returns
    -------
    list
        Per request, in order: the DataFrame of :func:`simulate` or the ``FallError`` it raises.

    Raises
    ------
    SimulationError
        For a request :func:`simulate` refuses, before any ride runs (set-up errors such as
        contact settings: as its batch is prepared).
    """
    if not (isinstance(batch, int) and batch >= 1 and isinstance(nthread, int) and nthread >= 0):
        raise engine.SimulationError(f"simulate_rides: batch must be a positive and nthread a non-negative "
                                     f"integer, got batch={batch!r}, nthread={nthread!r}")
    for r in requests:
        bad = set(r) - set(_SIM_KEYS)
        if bad:
            raise engine.SimulationError(f"simulate_rides: unknown argument {sorted(bad)[0]!r}; "
                                         f"valid: {', '.join(_SIM_KEYS)}")
    out: list = [None] * len(requests)
    in_batch = [i for i, r in enumerate(requests) if batchable(r)]
    if in_batch and not available():
        print(f"euc-sim: MuJoCo batch unavailable ({_callback()[1]}); simulating ride by ride",
              file=sys.stderr)
        in_batch = []
    batched = set(in_batch)
    for i, r in enumerate(requests):     # every request checked first (the batch's: all but set-up)
        if i in batched:
            _check(r)
        else:
            engine.prepare(**r)
    done = 0

    def finished(ids: list, results: list) -> None:
        nonlocal done
        for i, res in zip(ids, results):
            out[i] = res
        done += len(ids)
        if progress is not None:
            progress(done)

    if in_batch:                        # BLAS on one thread: its idle threads spin against the batch's
        with one_blas_thread(), exclusive(_callback()[0]):
            batches = _prepared_batches(requests, in_batch, batch)
            if nthread >= 2 and len(in_batch) >= PIPELINE_BATCHES * nthread * batch:
                _pipeline(batches, nthread, finished)
            else:
                for ids, rides, pushes in batches:
                    finished(ids, _run_batch(rides, pushes, nthread))
    for i, r in enumerate(requests):
        if i not in batched:
            try:
                res = engine.simulate(**r)
            except FallError as exc:
                res = exc
            finished([i], [res])
    return out


def _check(request: Mapping) -> None:
    """The checks of :func:`engine.prepare` that set nothing up (raise ``SimulationError``)."""
    bound = inspect.signature(engine.prepare).bind(**request)
    bound.apply_defaults()
    engine._check_request(**bound.arguments)


def _prepared_batches(requests: Sequence[Mapping], ids: list, size: int):
    """Yield (request indices, rides, external forces) of ``size`` rides at most, one
    ``Batch`` per (steps, delay, dt, ground); each ride is prepared as its batch is yielded.
    """
    groups: dict = {}
    for i in ids:
        ride = engine.prepare(**requests[i])
        key = (ride.N, ride.run.n, ride.run.dt, ride.stepper.sim.variant)
        group = groups.setdefault(key, [])
        group.append((i, ride, requests[i].get("external_force")))
        if len(group) == size:
            yield tuple(map(list, zip(*groups.pop(key))))
    for group in groups.values():
        yield tuple(map(list, zip(*group)))


def _pipeline(batches, nthread: int, finished) -> None:
    """Run ``batches`` on ``nthread`` threads, one ``Batch`` per thread at a time, while the
    calling thread prepares the next and calls ``finished(ids, results)``; a thread's failure
    is raised here after the threads stop.
    """
    todo: queue.Queue = queue.Queue(maxsize=nthread)
    results: queue.Queue = queue.Queue()
    failed = threading.Event()
    count = {"sent": 0, "reported": 0}

    def lane() -> None:
        while (item := todo.get()) is not None:
            if failed.is_set():
                continue
            try:
                results.put((item[0], _run_batch(item[1], item[2], 1)))
            except BaseException as exc:   # noqa: BLE001 - re-raised by the calling thread
                failed.set()
                results.put((None, exc))

    def report(block: bool) -> None:
        while count["reported"] < count["sent"]:
            try:
                ids, res = results.get(block=block)
            except queue.Empty:
                return
            count["reported"] += 1
            if ids is None:
                raise res
            finished(ids, res)
            block = False

    lanes = [threading.Thread(target=lane, name=f"mujoco_batch-{j}", daemon=True) for j in range(nthread)]
    for t in lanes:
        t.start()
    try:
        for item in batches:
            report(block=False)
            todo.put(item)
            count["sent"] += 1
        while count["reported"] < count["sent"]:
            report(block=True)
    except BaseException:
        failed.set()
        raise
    finally:
        for _ in lanes:
            todo.put(None)
        for t in lanes:
            t.join()


def _batch_model(ride, cache: dict):
    """The ride's model as :func:`simulate` builds it with :data:`NU` userdata slots, shared through ``cache``."""
    st = ride.stepper
    m0 = st.m
    key = (st.p, st.sim.variant, ride.ext.contact, float(m0.opt.timestep), tuple(m0.opt.gravity.tolist()),
           tuple(m0.dof_damping.tolist()), tuple(m0.tendon_damping.tolist()))
    if key not in cache:
        cache[key] = _compiled(*key)
    return cache[key]


@lru_cache(maxsize=64)
def _compiled(p, variant: str, contact, timestep: float, gravity: tuple, dof_damping: tuple,
              tendon_damping: tuple):
    """Compile the model of (parameters, ground, contact) with userdata and the stepper's settings."""
    spec = build_spec(p, variant, contact=contact)
    spec.nuserdata = NU
    m = spec.compile()
    m.opt.timestep = timestep
    m.opt.gravity[:] = gravity
    m.dof_damping[:] = dof_damping
    m.tendon_damping[:] = tendon_damping
    return m


def _userdata_row(ride, per: int, addrs: tuple, push_addr: int) -> np.ndarray:
    """One simulation's context (see the ``S_*`` slots)."""
    st, ext, p = ride.stepper, ride.ext, ride.p_true
    u = np.zeros(NU)
    u[[S_PER, S_ROWS, S_STATE, S_MD, S_MH, S_FALL]] = (per, ride.N + 1, *addrs, -1.0)
    u[[S_IX, S_IG, S_IR, S_VX, S_VG, S_VR, S_AM, S_AA, S_BR, S_BW]] = (
        st.ix, st.ig, st.ir, st.vx, st.vg, st.vr, st.a_motor, st.a_ankle, st.b_rider, st.b_wheel)
    u[S_SPIN] = 1.0 if st.spin else 0.0
    u[S_PHI], u[S_GAM] = ride.bounds["phi"], ride.bounds["gamma"]
    u[S_EFF] = 1.0 if ext.per_step else 0.0
    u[S_KDRAG], u[S_CRR], u[S_NLOAD] = ext.k_drag, ext.C_rr, ext.N_load
    u[S_R], u[S_PUSH] = p.R, push_addr
    u[S_MAGIC] = _MAGIC
    u[S_LAW:S_LAW + 11] = ride.motor.law_args()
    return u


def _run_batch(rides: list, forces: list, nthread: int) -> list:
    """Rides of equal length, delay and step as one ``Batch`` on ``nthread`` threads (0: MuJoCo's
    pool); results in order.  ``forces``: each ride's ``external_force`` F(t), N, or None.
    """
    S, N, n = len(rides), rides[0].N, rides[0].run.n
    cache: dict = {}
    models = [_batch_model(r, cache) for r in rides]
    P = np.zeros((S, N + 1 + n, 6))                 # padded state histories: the delay buffers
    MD, MH = np.zeros((S, N + 1)), np.zeros((S, N + 1))
    pushes = [None if F is None else np.array([float(F(k * r.run.dt)) for k in range(N)])
              for r, F in zip(rides, forces)]
    batch = mujoco.batch.Batch(models[0], S, nthread, False)
    batch.set_models(models[0] if len(cache) == 1 else models)
    qpos, qvel, warm, ud = batch.bind("qpos"), batch.bind("qvel"), batch.bind("qacc_warmstart"), batch.bind("userdata")
    for s, r in enumerate(rides):
        qpos[s], qvel[s], warm[s] = r.stepper.d.qpos, r.stepper.d.qvel, r.stepper.d.qacc_warmstart
        P[s, :n + 1] = r.y0
    per = _calls_per_step(models, rides)
    for s, r in enumerate(rides):
        ud[s] = _userdata_row(r, per, (P[s, n:].ctypes.data, MD[s].ctypes.data, MH[s].ctypes.data),
                              0 if pushes[s] is None else pushes[s].ctypes.data)
    law = _RiderBlocks([r.run for r in rides])
    st0 = rides[0].stepper
    out: list = [None] * S
    active = np.arange(S)
    for k0 in range(0, N + 1, n + 1):
        block = min(n + 1, N + 1 - k0)
        if k0:
            P[active, n + k0] = _states(qpos[active], qvel[active], st0)
        MH[active, k0:k0 + block] = law.applied(active, k0, P[active, k0:k0 + block])
        steps = block if k0 + block <= N else block - 1
        if steps:
            batch.step(active, nstep=steps)
            active = _drop_reset(active, ud, k0, steps, (rides, P, MD, MH, n), out)
        fell = active[ud[active, S_FALL] >= 0]
        for s in fell:
            out[s] = _fall(rides[s], P[s, n:], MD[s], MH[s], int(ud[s, S_FALL]))
        active = active[ud[active, S_FALL] < 0]
    final = _states(qpos[active], qvel[active], st0)
    for j, s in enumerate(active):
        r = rides[s]
        P[s, n + N] = final[j]
        P[s, n] = r.y0                              # as given, not as read back from qpos
        y = tuple(final[j].tolist())
        bad = not (abs(y[2]) <= r.bounds["phi"] and abs(y[1]) <= r.bounds["gamma"] and np.isfinite(final[j]).all())
        if bad:
            out[s] = _fall(r, P[s, n:], MD[s], MH[s], N)
            continue
        MD[s, N] = r.motor.torque(y[1], y[4], y[3])
        out[s] = r.frame(P[s, n:].copy(), np.column_stack([MD[s], MH[s]]))
    return out


def _drop_reset(active: np.ndarray, ud: np.ndarray, k0: int, steps: int, run, out: list) -> np.ndarray:
    """The simulations of ``active`` still running after a block; those MuJoCo reset (its
    ``mj_resetData`` zeroes the step count) get an :class:`UnstableError` in ``out``.
    """
    rides, P, MD, MH, n = run
    lost = ud[active, S_K] != k0 + steps
    for s in active[lost]:
        if ud[s, S_K] != 0:
            raise RuntimeError("mujoco_batch: the callback's step count lost step with the batch")
        exc = UnstableError(k0 * rides[s].run.dt, "seen as its step count reset to 0")
        exc.partial = (P[s, n:n + k0].copy(), np.column_stack([MD[s, :k0], MH[s, :k0]]))
        rides[s].attach_partial(exc)
        out[s] = exc
    return active[~lost]


def _states(qpos: np.ndarray, qvel: np.ndarray, st) -> np.ndarray:
    """(x, γ, φ, ẋ, γ̇, φ̇) per row of the bound qpos, qvel."""
    g, gd = qpos[:, st.ig], qvel[:, st.vg]
    return np.column_stack([qpos[:, st.ix], g, g + qpos[:, st.ir], qvel[:, st.vx], gd, gd + qvel[:, st.vr]])


def _fall(ride, states: np.ndarray, M_d: np.ndarray, M_h: np.ndarray, k: int) -> FallError:
    """The ``FallError`` :func:`simulate` raises at step k, with the run up to it."""
    try:
        engine._raise_fall(k * ride.run.dt, tuple(states[k].tolist()), ride.bounds["phi"], ride.bounds["gamma"])
    except FallError as exc:
        exc.partial = (states[:k].copy(), np.column_stack([M_d[:k], M_h[:k]]))
        ride.attach_partial(exc)
        return exc
    raise RuntimeError(f"mujoco_batch: step {k} was flagged as a fall but is within the bounds")


def _calls_per_step(models: list, rides: list) -> int:
    """Callback calls per ``mj_step`` (4 with RK4), counted on a 1-simulation batch."""
    probe = mujoco.batch.Batch(models[0], 1, 1, False)
    row = np.zeros(NU)
    row[[S_PER, S_AM, S_AA, S_MAGIC]] = (1.0, rides[0].stepper.a_motor, rides[0].stepper.a_ankle, _MAGIC)
    probe.bind("userdata")[0] = row
    probe.step(nstep=1)                              # inside the caller's native_core.exclusive
    calls = int(probe.bind("userdata")[0, S_CALLS])
    if calls < 1:
        raise RuntimeError("the control callback was not called by the batch's mj_step")
    return calls


class _RiderBlocks:
    """:meth:`euc_sim.controllers.rider.RiderRun.commands` vectorised across many runs.

    Each run's ``du`` becomes a row view of the stack, so that a run done by its own
    :meth:`commands` (the torque limit binds) shares the history; runs of one rider law
    are solved together.
    """

    def __init__(self, runs: list):
        self.runs = runs
        self.v_ref = np.stack([r.v_ref for r in runs])
        self.gamma_ref = np.stack([r.gamma_ref for r in runs])
        self.phi_ref = np.stack([r.phi_ref for r in runs])
        self.u_ref = np.stack([r.u_ref for r in runs])
        self.noise = np.stack([r.noise for r in runs])
        self.du = np.stack([r.du for r in runs])
        for i, r in enumerate(runs):
            r.du = self.du[i]
        self.z = np.array([r.z for r in runs])
        law = {}
        for i, r in enumerate(runs):
            law.setdefault((id(r._chunk[0]), r.k_pred, r.integral, r.limit), []).append(i)
        self.law_of = np.empty(len(runs), dtype=int)
        self.laws = []
        for j, members in enumerate(law.values()):
            self.law_of[members] = j
            self.laws.append(runs[members[0]])

    def applied(self, ids: np.ndarray, k0: int, Y: np.ndarray) -> np.ndarray:
        """Applied M_h (with noise), N·m, (len(ids), L), of steps k0 … k0 + L − 1 for runs ``ids``
        from the sensed states ``Y`` (len(ids), L, 6).
        """
        out = np.empty(Y.shape[:2])
        for j, ref in enumerate(self.laws):
            sel = np.flatnonzero(self.law_of[ids] == j)
            if sel.size:
                out[sel] = self._one_law(ref, ids[sel], k0, Y[sel])
        return out

    def _one_law(self, ref, ids: np.ndarray, k0: int, y: np.ndarray) -> np.ndarray:
        """:meth:`RiderRun.commands` (its operations, in order) for runs of one law."""
        L, n = y.shape[1], ref.n
        kp, j = ref.k_pred, slice(k0, k0 + L)
        z0, du0 = self.z[ids], self.du[ids, k0:k0 + n]
        e_v = y[:, :, 3] - self.v_ref[ids, j]
        fb = (kp[0] * e_v + kp[1] * (y[:, :, 1] - self.gamma_ref[ids, j])
              + kp[2] * (y[:, :, 2] - self.phi_ref[ids, j]) + kp[3] * y[:, :, 4] + kp[4] * y[:, :, 5])
        z_end = z0
        if ref.integral:
            z = np.cumsum(np.column_stack([z0, e_v * ref.dt]), axis=1)
            fb += kp[5] * z[:, :L]
            z_end = z[:, L]
        rhs = -fb
        if n:
            lower, past = ref._chunk
            rhs -= du0 @ past[:L].T
            if L < n + 1:
                lower = np.asfortranarray(lower[:L, :L])
            du, info = dtrtrs(lower, np.asfortranarray(rhs.T), lower=1, unitdiag=1)
            du = du.T
        else:
            du = rhs
        u = self.u_ref[ids, k0 + n:k0 + n + L] + du
        self.z[ids] = z_end
        self.du[ids, k0 + n:k0 + n + L] = du
        applied = u + self.noise[ids, k0:k0 + L]
        for i in np.flatnonzero(np.any(np.abs(u) > ref.limit, axis=1)):   # the limit binds: that run alone
            run, s = self.runs[ids[i]], ids[i]
            self.du[s, k0:k0 + n] = du0[i]
            run.z = float(z0[i])
            applied[i] = run.commands(k0, y[i])[1]
            self.z[s] = run.z
        return applied
