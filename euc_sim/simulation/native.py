"""The planar MuJoCo closed loop without Python per step: motor and rider as a native callback.

The motor PD (:func:`euc_sim.controllers.motor.pd_torque`) and the rider's delayed LQR with its
predictor, integral speed tracking and motor noise (:func:`euc_sim.controllers.rider.delayed_lqr_torque`
on the buffers of :class:`euc_sim.controllers.rider.RiderRun`) are compiled by numba into MuJoCo's
control callback (:mod:`euc_sim.simulation.native_kernels`).  At the first callback call
of each step (RK4 calls it once per stage; the count per step is measured on the model,
not assumed) the callback records the state, computes M_d from it and M_h from the
state n steps old and the last n commands, and holds both over the step (zero-order
hold at dt), with the step's held drag, rolling-resistance moment and external force
(:func:`euc_sim.simulation.effects.held_forces` from ẋ at its start, as the Python loop
holds them) and generalised forces of yaw and tilt (``lateral_dynamics``,
:func:`~euc_sim.simulation.effects.lateral_force_row`) and of a moving centre of gravity
(``cog_height_drift``, :func:`~euc_sim.simulation.drift.drift_force_row`, with h(t) in the
model's ``body_ipos``).  ``mj_step(model, data, nstep)`` then runs the whole ride in C, in chunks
between which Python only looks for a fall (and reports progress).

The run's state lives in its own context (:mod:`euc_sim.simulation.native_core`),
registered for its ``MjData`` only: runs on several threads go native together.  The
rider's ``du`` buffer is the :class:`RiderRun`'s own; its z is written back at the end.

The rider's per-step law is the Python reference's (:meth:`RiderRun.command`) step by
step, where the Python loop solves each block of n + 1 steps at once
(:meth:`RiderRun.commands`): the two loops agree to rounding (≤ 1e-9 rad over a ride,
``tests/simulation/test_native.py``), not bit for bit.

Where numba is missing or cannot compile, :func:`native_loop` says so in one line on
stderr and returns ``None``; the caller runs the Python loop.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import RiderRun
from euc_sim.simulation import native_core as nc
from euc_sim.simulation import native_layout as lay
from euc_sim.simulation.errors import FallError

__all__ = ["native_loop", "planar_context", "available", "LAST_RUN"]

#: The last native run of this process: rows recorded by the callback, its calls, calls per step.
LAST_RUN: dict = {}

available = nc.available


def native_loop(stepper, motor: MotorPD, run: RiderRun, dt: float, N: int, y0: tuple,
                bounds: Mapping[str, float], raise_fall,
                progress=None, forces=None, moving=None) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`euc_sim.simulation.engine._closed_loop` for a MuJoCo stepper.

    Same states (N+1, 6) and torques (N+1, 2); ``None`` (and one line on stderr) when the
    callback cannot be built: the caller then runs the Python loop.  ``raise_fall(t, y,
    phi_max, gam_max)`` raises at the first recorded state outside ``bounds``, as the
    Python loop does; the ``FallError`` carries ``partial``, the states and torques of
    steps 0 … k − 1, as the Python loop's does.  ``progress(t)``: the simulated time, s,
    at every rider block (n + 1 steps), as in the Python loop.  ``forces``: ``(k_drag,
    C_rr, N_load, R, F)`` of :func:`euc_sim.simulation.effects.held_forces`, ``F`` the
    ``external_force`` callable F(t) or None, applied at every step; None: none.
    ``moving``: with ``forces``, the held generalised forces of ``lateral_dynamics`` and
    ``cog_height_drift``, ``(table3, lat, lat_scale, h)``: ``table3`` the 11 numbers of
    :func:`euc_sim.simulation.effects.lateral_force_row` (mw … J), ``lat`` (N, 5) rows
    (sin ϑ, cos ϑ, ϑ̇, ψ̇, ψ̈) or None, ``h`` (N + 1, 3) rows (h, ḣ, ḧ) or None (then
    h_k is also the model's ``body_ipos`` of ``rider`` over step k; h_0 must be in the model).
    """
    if nc.callback() is None:
        return None
    return _run(stepper, motor, run, dt, N, y0, bounds, raise_fall, progress, forces, moving)


def planar_context(stepper, motor: MotorPD, run: RiderRun, N: int, y0: tuple, bounds, forces=None,
                   dt: float = 0.0, moving=None):
    """A planar run's context (:mod:`euc_sim.simulation.native_layout`) for ``stepper.d``.

    Parameters as :func:`native_loop`; an external force F(t) is tabulated at k·dt, k < N.  To run it elsewhere (a thread, a batch): set
    ``ctx.c[C_PER]`` to :func:`native_core.calls_per_step`, register the ``MjData`` with
    :func:`native_core.registered`, ``mj_step`` it N steps, then set ``ctx.c[C_CALLS] = 0``
    and ``mj_forward`` it once for the last row.

    Returns
    -------
    tuple
        The :class:`native_core.Context` and the arrays the callback fills: padded state
        history P (N + 1 + n, 6; row n + k is step k), M_d and M_h (N + 1,), N·m.
    """
    n = run.n
    ctx = nc.Context(lay.KIND_PLANAR, N + 1)
    P = ctx.put(lay.P_HIST, np.empty((N + 1 + n, 6)))      # padded state history: the delay buffer
    P[:n + 1] = y0                                         # row 0 is y0 as given
    M_d = ctx.put(lay.P_MD, np.zeros(N + 1))
    M_h = ctx.put(lay.P_MH, np.zeros(N + 1))
    ctx.c[lay.P_IX:lay.P_VR + 1] = (stepper.ix, stepper.ig, stepper.ir, stepper.vx, stepper.vg, stepper.vr)
    ctx.actuators(stepper.a_motor, stepper.a_ankle)
    ctx.f[:11] = motor.law_args()
    ctx.f[lay.F_PHI_MAX], ctx.f[lay.F_GAM_MAX] = bounds["phi"], bounds["gamma"]
    ctx.rider(lay.P_RIDER, run)
    if forces is not None:
        k_drag, C_rr, N_load, R, F = forces
        ctx.c[lay.P_EFF:lay.P_SPIN + 1] = (1, 0, stepper.b_rider, stepper.b_wheel, int(stepper.spin))
        ctx.f[lay.F_KDRAG:lay.F_R + 1] = (k_drag, C_rr, N_load, R)
        if F is not None:          # F(t) on the grid, as the Python loop evaluates it at each step
            ctx.put(lay.P_PUSH, np.array([float(F(k * dt)) for k in range(N)]))
    if moving is not None:
        table3, lat, lat_scale, h = moving
        ctx.f[lay.F_TABLE3:lay.F_TABLE3 + 11] = table3
        ctx.f[lay.F_LSCALE] = lat_scale
        if lat is not None:
            ctx.put(lay.P_LAT, np.ascontiguousarray(lat, dtype=np.float64).reshape(-1, 5))
        if h is not None:
            ctx.put(lay.P_DRIFT, np.ascontiguousarray(h, dtype=np.float64).reshape(-1, 3))
            ctx.c[lay.P_SITE_G] = stepper.site_G
    return ctx, P, M_d, M_h


def _run(stepper, motor, run, dt, N, y0, bounds, raise_fall, progress=None, forces=None, moving=None):
    """:func:`native_loop` with the callback built."""
    n = run.n
    ctx, P, M_d, M_h = planar_context(stepper, motor, run, N, y0, bounds, forces, dt, moving)
    phi_max, gam_max = bounds["phi"], bounds["gamma"]
    if progress is None:
        nc.ride(stepper.m, stepper.d, ctx, N)
    else:
        nc.ride(stepper.m, stepper.d, ctx, N, chunk=n + 1, progress=lambda k: progress(k * dt))
    run.z = ctx.rider_z(lay.P_RIDER)
    LAST_RUN.update(rows=int(ctx.c[lay.C_K]), calls=int(ctx.c[lay.C_CALLS]), per=int(ctx.c[lay.C_PER]))
    if ctx.c[lay.C_FALL] >= 0:
        k = int(ctx.c[lay.C_FALL])
        try:
            _check_falls(P[n + k:n + k + 1], k, dt, phi_max, gam_max, raise_fall)
        except FallError as exc:          # the states and torques of steps 0 … k − 1
            exc.partial = (P[n:n + k].copy(), np.column_stack([M_d[:k], M_h[:k]]))
            raise
    return P[n:], np.column_stack([M_d, M_h])


def _check_falls(rows: np.ndarray, k0: int, dt: float, phi_max: float, gam_max: float, raise_fall) -> None:
    """Raise at the first row with |φ| > φ_max, |γ| > γ_max or a non-finite value."""
    ok = (np.abs(rows[:, 2]) <= phi_max) & (np.abs(rows[:, 1]) <= gam_max) & np.isfinite(rows).all(axis=1)
    if not ok.all():
        j = int(np.argmin(ok))
        raise_fall((k0 + j) * dt, tuple(rows[j].tolist()), phi_max, gam_max)
