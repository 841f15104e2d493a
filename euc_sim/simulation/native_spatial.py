"""The 3-D MuJoCo closed loop without Python per step (:func:`euc_sim.simulation.spatial.simulate_3d`).

The loop of ``spatial._ride`` as the callback's spatial kernel
(:func:`euc_sim.simulation.native_kernels.spatial_step`).  The Python loop stays the
reference and the fallback; without a lateral delay the two agree bit for bit, with one
to rounding (the predictor's sums in another order).
"""

from __future__ import annotations

import numpy as np

from euc_sim.controllers.lateral import LateralRider
from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import RiderRun
from euc_sim.simulation import native_core as nc
from euc_sim.simulation import native_layout as lay
from euc_sim.simulation.errors import FallError
from euc_sim.simulation.mocap import E_HEIGHT

__all__ = ["native_ride", "spatial_context", "ROW_COLUMNS", "LAST_RUN"]

#: Columns of a recorded row (``spatial._ride``'s order).
ROW_COLUMNS = ("t", "x", "gamma", "phi", "x_dot", "gamma_dot", "phi_dot", "M_d", "M_h", "v_ref", "psi",
               "theta", "psi_dot", "theta_dot", "M_lean", "M_twist", "e_y",
               "C_X", "C_Y", "C_Z", "E_X", "E_Y", "E_Z", "G_X", "G_Y", "G_Z")
#: The last native 3-D run of this process: rows recorded by the callback.
LAST_RUN: dict = {}
_FALL_KINDS = ("state", "theta", "phi", "gamma")


def native_ride(sim, run: RiderRun, motor: MotorPD, lateral: LateralRider, path, v_ref: np.ndarray,
                N: int, dt: float, y0: tuple, bounds: dict, tilt_bound: float,
                turn_effort_time: float) -> np.ndarray | None:
    """``spatial._ride`` natively: the rows (N + 1, 26) in :data:`ROW_COLUMNS`' order, or ``None``
    (one line on stderr) when the callback cannot be built.

    ``sim`` is set to its initial state; ``run``'s ``du`` and ``z`` advance as in the Python
    loop; ``v_ref`` (N + 1,) m/s; ``y0`` the planar state before t = 0; ``bounds``
    (``phi``, ``gamma``) and ``tilt_bound``, rad; ``turn_effort_time``, s.  ``FallError`` at
    the first step out of bounds.
    """
    if nc.callback() is None:
        return None
    ctx, out = spatial_context(sim, run, motor, lateral, path, v_ref, N, dt, y0, bounds, tilt_bound,
                        turn_effort_time)
    nc.ride(sim.model, sim.data, ctx, N)
    run.z = ctx.rider_z(lay.S_RIDER)
    LAST_RUN.update(rows=int(ctx.c[lay.C_K]), per=int(ctx.c[lay.C_PER]))
    if ctx.c[lay.C_FALL] >= 0:
        kind = _FALL_KINDS[int(ctx.c[lay.S_FALL_KIND])]
        bound = {"state": None, "theta": tilt_bound, "phi": bounds["phi"], "gamma": bounds["gamma"]}[kind]
        raise FallError(int(ctx.c[lay.C_FALL]) * dt, kind, float(ctx.f[lay.F_FALL_VALUE]), bound)
    return out


def spatial_context(sim, run, motor, lateral, path, v_ref, N, dt, y0, bounds, tilt_bound, turn_effort_time):
    """A 3-D run's context for ``sim.data`` and the rows (N + 1, 26) the callback fills (parameters as :func:`native_ride`)."""
    ctx = nc.Context(lay.KIND_SPATIAL, N + 1)
    out = ctx.put(lay.S_OUT, np.zeros((N + 1, len(ROW_COLUMNS))))
    n = run.n
    hist = ctx.put(lay.S_HIST, np.empty((N + 1 + n, 6)))
    hist[:n] = y0
    ctx.put(lay.S_PLAN, np.ascontiguousarray(v_ref, dtype=np.float64))
    for slot, arr in ((lay.S_PX, path.X), (lay.S_PY, path.Y), (lay.S_PH, path.heading), (lay.S_PK, path.kappa)):
        ctx.put(slot, np.ascontiguousarray(arr, dtype=np.float64))
    ctx.c[lay.S_PN], ctx.c[lay.S_PI] = len(path.X), 0
    qa, va = sim.qadr, sim.vadr
    ctx.c[lay.S_RQ:lay.S_VT + 1] = (qa["root"], va["root"], qa["rider_pitch"], qa["rider_lean"],
                                  qa["rider_twist"], va["rider_pitch"], va["rider_lean"], va["rider_twist"])
    ctx.actuators(*(sim.act[a] for a in ("motor", "ankle", "lean", "twist")))
    nd = lateral.n_delay
    ctx.c[lay.S_ND] = nd
    ctx.put(lay.S_K, np.ascontiguousarray(np.asarray(lateral.K, dtype=np.float64).reshape(2, 11)))
    if nd:
        ctx.put(lay.S_KP, np.ascontiguousarray(np.asarray(lateral.K_pred, dtype=np.float64)))
        ctx.put(lay.S_KH, np.ascontiguousarray(np.asarray(lateral.K_hist, dtype=np.float64)))
        ctx.put(lay.S_ZHIST, np.zeros((N + 1, 11)))
        ctx.put(lay.S_UHIST, np.zeros(2 * (N + 1 + nd)))
    f, p = ctx.f, sim.params
    f[:11] = motor.law_args()
    f[lay.F_PHI_MAX], f[lay.F_GAM_MAX], f[lay.F_TILT] = bounds["phi"], bounds["gamma"], tilt_bound
    f[lay.F_DT], f[lay.F_LAT_LIM], f[lay.F_G] = dt, lateral.torque_limit, p.g
    f[lay.F_ABAR] = dt / turn_effort_time
    f[lay.F_H], f[lay.F_L0], f[lay.F_EH] = p.h, p.l0, E_HEIGHT
    ctx.rider(lay.S_RIDER, run)
    return ctx, out
