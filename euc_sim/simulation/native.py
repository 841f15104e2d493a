"""The planar MuJoCo closed loop without Python per step: motor and rider as a native callback.

The motor PD, the rider's delayed LQR with its predictor and the held external forces
(drag, rolling resistance, ``external_force``, ``lateral_dynamics``, ``cog_height_drift``
with h(t) in the model) run in the compiled callback of
:mod:`euc_sim.simulation.native_kernels` at the first call of each step; ``mj_step`` runs
the ride in C in chunks, Python only looking for a fall.  The rider's law goes step by
step where the Python loop solves blocks: the two agree to rounding.  Where numba cannot
compile, :func:`native_loop` returns ``None`` after one line on stderr.
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
    """:func:`euc_sim.simulation.engine._closed_loop` for a MuJoCo stepper: states (N+1, 6) and
    torques (N+1, 2), or ``None`` when the callback cannot be built.

    ``raise_fall(t, y, phi_max, gam_max)`` raises at the first state outside ``bounds`` (its
    ``partial``: steps 0 … k − 1); ``progress(t)`` every rider block; ``forces``:
    ``(k_drag, C_rr, N_load, R, F)`` of :func:`~euc_sim.simulation.effects.held_forces` (F(t)
    or None); ``moving``: ``(table3, lat, lat_scale, h)``, the 11 parameters of
    :func:`~euc_sim.simulation.lateral.lateral_force_row`, rows (sin ϑ, cos ϑ, ϑ̇, ψ̇, ψ̈) and
    (h, ḣ, ḧ) or None.
    """
    if nc.callback() is None:
        return None
    n = run.n
    ctx, P, M_d, M_h = planar_context(stepper, motor, run, N, y0, bounds, forces, dt, moving)
    phi_max, gam_max = bounds["phi"], bounds["gamma"]
    if progress is None:
        nc.ride(stepper.m, stepper.d, ctx, N)
    else:
        nc.ride(stepper.m, stepper.d, ctx, N, chunk=n + 1, progress=lambda k: progress(k * dt))
    run.z = ctx.rider_z(lay.P_RIDER)
    LAST_RUN.update(rows=int(ctx.c[lay.C_K]), calls=int(ctx.c[lay.C_CALLS]), per=int(ctx.c[lay.C_PER]))
    k = int(ctx.c[lay.C_FALL])
    y = P[n + k]
    if k >= 0 and not (abs(y[2]) <= phi_max and abs(y[1]) <= gam_max and np.isfinite(y).all()):
        try:
            raise_fall(k * dt, tuple(y.tolist()), phi_max, gam_max)
        except FallError as exc:          # the states and torques of steps 0 … k − 1
            exc.partial = (P[n:n + k].copy(), np.column_stack([M_d[:k], M_h[:k]]))
            raise
    return P[n:], np.column_stack([M_d, M_h])


def planar_context(stepper, motor: MotorPD, run: RiderRun, N: int, y0: tuple, bounds, forces=None,
                   dt: float = 0.0, moving=None):
    """A planar run's context for ``stepper.d`` (parameters as :func:`native_loop`) and the arrays
    the callback fills: the padded state history (N + 1 + n, 6; row n + k is step k), M_d and
    M_h (N + 1,), N·m.  Run it with :func:`native_core.ride`.
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
