"""The batch engine: N closed-loop rides at once, vectorised over rides.

One fixed-step RK4 step of eqs. (5)-(8) advances every ride; the motor PD
(:class:`euc_sim.controllers.motor.MotorPD`) and the rider's law (:class:`euc_sim.controllers.rider.RiderRun`:
trim, feedback, delay buffer, delay-compensating predictor, torque limit, motor
noise) are the same linear laws written as array operations over the rides.
Each ride has its own maneuver and noise seed; the parameters, motor and rider
are shared (the Monte Carlo of one rider).  :func:`simulate_batch` matches
:func:`euc_sim.simulation.engine.simulate` (MuJoCo RK4 and the analytic DOP853
engine) to 1e-9 rad (``tests/scripts/test_batch_engine.py``).

Not here: the catalog's effects and the contact ground (use the per-ride engine);
a ride that falls is frozen at its fall and flagged (``BatchRun.fell``).

Role: a cross-check only.  Studies (``dataset``, the blind study,
both ``design`` modules) run their rides through MuJoCo batches on threads
(:mod:`euc_sim.simulation.mujoco_batch`, every batchable effect, both grounds);
this engine, a second and independent integration of eqs. (5)-(8), is held to
MuJoCo by ``tests/scripts/test_batch_engine.py`` and timed beside it in
``scripts/bench.py batch``.

Layout: the state is an array of shape (6, R), rows (x, γ, φ, ẋ, γ̇, φ̇) in the
paper's coordinates, so each row is a contiguous vector over rides.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import Rider, RiderRun, motor_noise
from euc_sim.model.parameters import Params, TABLE3
from euc_sim.simulation.engine import DEFAULT_DT, FALL_BOUNDS, default_rider
from euc_sim.simulation.errors import SimulationError
from euc_sim.simulation.maneuvers import as_maneuver

__all__ = ["BatchRun", "simulate_batch", "state_derivative"]


@dataclass(frozen=True)
class BatchRun:
    """R rides on a common time grid (every ``stride``-th control step).

    Attributes
    ----------
    t : ndarray, shape (M,)
        Times, s.
    y : ndarray, shape (M, 6, R)
        State (x [m], γ, φ [rad], ẋ [m/s], γ̇, φ̇ [rad/s]) of each ride.
    M_d, M_h : ndarray, shape (M, R)
        Motor torque and applied ankle torque held over the step, N·m.
    v_ref : ndarray, shape (M, R)
        Planned speed, m/s.
    fell : ndarray of bool, shape (R,)
    t_fall : ndarray, shape (R,)
        Time of the fall, s (NaN when the ride did not fall); the state is frozen after it.
    """

    t: np.ndarray
    y: np.ndarray
    M_d: np.ndarray
    M_h: np.ndarray
    v_ref: np.ndarray
    fell: np.ndarray
    t_fall: np.ndarray

    def ride(self, r: int) -> pd.DataFrame:
        """Ride ``r`` in :func:`euc_sim.simulation.engine.simulate`'s columns."""
        y = self.y[:, :, r]
        return pd.DataFrame({"t": self.t, "x": y[:, 0], "gamma": y[:, 1], "phi": y[:, 2],
                             "x_dot": y[:, 3], "gamma_dot": y[:, 4], "phi_dot": y[:, 5],
                             "M_d": self.M_d[:, r], "M_h": self.M_h[:, r], "v_ref": self.v_ref[:, r]})


def _constants(p: Params) -> dict:
    return {"A": p.m * p.l0 - p.m0 * p.h0, "B": p.m * p.h, "l0": p.l0, "g": p.g, "R": p.R,
            "m11": p.m + p.m0 + p.mw + p.Jw / p.R**2, "m22": p.J0 + p.m0 * p.h0**2 + p.m * p.l0**2,
            "m33": p.J + p.m * p.h**2}


def state_derivative(c: Mapping[str, float], Y: np.ndarray, M_d: np.ndarray, M_h: np.ndarray) -> np.ndarray:
    """ẏ of eq. (5) for every ride: (q̇, M⁻¹(Q − h)) with the 3×3 solve by cofactors.

    Parameters
    ----------
    c : mapping
        Constants of :func:`_constants` (A = m l₀ − m₀ h₀, B = m h, m₁₁, m₂₂, m₃₃, l₀, g, R).
    Y : ndarray, shape (6, R)
    M_d, M_h : ndarray, shape (R,)
        Torques, N·m.

    Returns
    -------
    ndarray, shape (6, R)
    """
    g_, f_, gd, fd = Y[1], Y[2], Y[4], Y[5]
    A, B, l0 = c["A"], c["B"], c["l0"]
    s_g, c_g, s_f, c_f = np.sin(g_), np.cos(g_), np.sin(f_), np.cos(f_)
    s_fg = s_f * c_g - c_f * s_g                         # sin(φ − γ)
    c_fg = c_f * c_g + s_f * s_g                         # cos(φ − γ)
    m11, m22, m33 = c["m11"], c["m22"], c["m33"]
    m12, m13, m23 = -A * c_g, B * c_f, -B * l0 * c_fg     # eq. (6)
    fd2, gd2 = fd * fd, gd * gd
    # r = Q − h: eqs. (8) and (7)
    r1 = M_d / c["R"] + B * fd2 * s_f - A * gd2 * s_g
    r2 = M_h - M_d - A * c["g"] * s_g - B * l0 * fd2 * s_fg
    r3 = B * c["g"] * s_f - M_h + B * l0 * gd2 * s_fg
    C11 = m22 * m33 - m23 * m23
    C12 = m13 * m23 - m12 * m33
    C13 = m12 * m23 - m13 * m22
    C22 = m11 * m33 - m13 * m13
    C23 = m12 * m13 - m11 * m23
    C33 = m11 * m22 - m12 * m12
    inv_det = 1.0 / (m11 * C11 + m12 * C12 + m13 * C13)
    out = np.empty_like(Y)
    out[:3] = Y[3:]
    out[3] = (C11 * r1 + C12 * r2 + C13 * r3) * inv_det
    out[4] = (C12 * r1 + C22 * r2 + C23 * r3) * inv_det
    out[5] = (C13 * r1 + C23 * r2 + C33 * r3) * inv_det
    return out


def _rider_tables(maneuvers, seeds, N: int, p: Params, motor: MotorPD, rider: Rider, dt: float):
    """References on the padded timeline (shape (N+1+n, U), one column per distinct
    maneuver, ``group`` maps rides to columns), motor noise (N+1, R) and the shared
    gains, taken from :class:`RiderRun` and :func:`motor_noise` so both engines use one law."""
    t = np.arange(N + 1) * dt
    distinct = list(dict.fromkeys(maneuvers))
    runs, plans = [], []
    for man in distinct:
        v_ref, a_ref = man.reference(t)
        plans.append(v_ref)
        runs.append(RiderRun(rider, p, motor, v_ref, a_ref, dt, 0))
    group = np.array([distinct.index(m) for m in maneuvers])
    col = lambda attr: np.ascontiguousarray(np.array([getattr(r, attr) for r in runs]).T)  # noqa: E731
    noise = np.empty((N + 1, len(seeds)))
    for r, seed in enumerate(seeds):                   # as RiderRun draws it for seed ``seed``
        noise[:, r] = motor_noise(N + 1, dt, rider.noise_std, rider.noise_tau, seed)
    first = runs[0]
    y0 = np.array([r.initial_state()[:3] for r in runs]).T[:, group]
    return {"v_plan": np.ascontiguousarray(np.array(plans).T), "v": col("v_ref"), "gamma": col("gamma_ref"),
            "phi": col("phi_ref"), "u": col("u_ref"), "noise": noise, "n": first.n, "group": group,
            "k_pred": np.array(first.k_pred), "k_hist": first.k_hist, "integral": first.integral,
            "limit": first.limit, "y0": y0}


def simulate_batch(maneuvers: Sequence, duration: float, *, seeds: Sequence[int],
                   params: Params = TABLE3, motor: MotorPD | None = None, rider: Rider | None = None,
                   dt: float = DEFAULT_DT, fall_bounds: Mapping[str, float] | None = None,
                   stride: int = 1) -> BatchRun:
    """Simulate R rides at once: ride r runs ``maneuvers[r]`` with motor-noise seed ``seeds[r]``.

    Parameters
    ----------
    maneuvers : sequence of str or Maneuver
        One per ride.
    duration : float
        Length of every ride, s.
    seeds : sequence of int
        Rider motor-noise seeds, one per ride (as :func:`simulate`'s ``seed``).
    params : Params
        The physics and the rider's model of it (no effects).
    motor : MotorPD, optional
    rider : Rider, optional
        Default: :func:`euc_sim.simulation.engine.default_rider` of ``params``.
    dt : float
        Control period and RK4 step, s.
    fall_bounds : mapping, optional
        ``{"phi": rad, "gamma": rad}`` (default ``FALL_BOUNDS``).
    stride : int
        Keep every ``stride``-th step in the output (1: all, as :func:`simulate`).

    Returns
    -------
    BatchRun
    """
    if len(maneuvers) != len(seeds) or not len(seeds):
        raise SimulationError(f"simulate_batch: expected one seed per maneuver (at least one ride), "
                              f"got {len(maneuvers)} maneuvers and {len(seeds)} seeds")
    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise SimulationError(f"duration must be a positive number of seconds, got {duration!r}")
    if not (isinstance(stride, int) and stride >= 1):
        raise SimulationError(f"stride must be a positive integer, got {stride!r}")
    motor = motor or MotorPD()
    rider = rider or default_rider(params, motor)
    bounds = {**FALL_BOUNDS, **(fall_bounds or {})}
    N = int(round(duration / dt))
    tab = _rider_tables([as_maneuver(m) for m in maneuvers], [int(s) for s in seeds], N, params, motor,
                        rider, dt)
    return _loop(tab, N, dt, _constants(params), motor, bounds, stride)


def _loop(tab: dict, N: int, dt: float, c: dict, motor: MotorPD, bounds: dict, stride: int) -> BatchRun:
    n, R, grp = tab["n"], tab["noise"].shape[1], tab["group"]
    V, G, F, U, W = tab["v"], tab["gamma"], tab["phi"], tab["u"], tab["noise"]
    if V.shape[1] not in (1, R) or (V.shape[1] == R and np.any(grp != np.arange(R))):
        V, G, F, U = (a[:, grp] for a in (V, G, F, U))   # one column per ride
    kp, lim = tab["k_pred"], tab["limit"]
    KG = tab["k_hist"]
    rolled = np.array([np.roll(KG, j) for j in range(n)]) if n else None  # weights by ring slot
    Y = np.zeros((6, R))
    Y[1], Y[2], Y[3] = tab["y0"][1], tab["y0"][2], tab["y0"][0]
    ring = np.repeat(Y[None], n + 1, axis=0)             # delayed states, slot j % (n+1)
    du = np.zeros((R, n))                                # last n commands − trim, slot j % n
    z = np.zeros(R)
    alive = np.ones(R, bool)
    t_fall = np.full(R, np.nan)
    M = N // stride + 1
    out_y, out_d, out_h = np.empty((M, 6, R)), np.empty((M, R)), np.empty((M, R))
    Kp, Kd, mlim = motor.Kp, motor.Kd, motor.torque_limit
    tilt = math.isfinite(motor.tiltback_speed)
    pm, gm, h2, h6 = bounds["phi"], bounds["gamma"], 0.5 * dt, dt / 6.0
    for k in range(N + 1):
        ok = (np.abs(Y[2]) <= pm) & (np.abs(Y[1]) <= gm)
        if not ok.all() and (newly := alive & ~ok).any():
            t_fall[newly] = k * dt
            alive &= ok
        g_ref = 0.0
        if tilt:                                          # motor.gamma_ref, vectorised
            excess = np.abs(Y[3]) - motor.tiltback_speed
            g_ref = np.where(excess > 0, -np.sign(Y[3]) * motor.tiltback_gain * excess, 0.0)
        M_d = np.minimum(np.maximum(Kp * (Y[1] - g_ref) + Kd * Y[4], -mlim), mlim)
        s = ring[k % (n + 1)]                             # the state the rider senses (RiderRun.command)
        e_v = s[3] - V[k]
        fb = kp[0] * e_v + kp[1] * (s[1] - G[k]) + kp[2] * (s[2] - F[k]) + kp[3] * s[4] + kp[4] * s[5]
        if tab["integral"]:
            fb += kp[5] * z
            z += e_v * dt
        if n:
            fb += du @ rolled[k % n]
        u = np.minimum(np.maximum(U[k + n] - fb, -lim), lim)
        if n:
            du[:, k % n] = u - U[k + n]
        M_h = u + W[k]
        if k % stride == 0:
            out_y[k // stride], out_d[k // stride], out_h[k // stride] = Y, M_d, M_h
        if k == N:
            break
        k1 = state_derivative(c, Y, M_d, M_h)             # RK4, torques held over the step
        k2 = state_derivative(c, Y + h2 * k1, M_d, M_h)
        k3 = state_derivative(c, Y + h2 * k2, M_d, M_h)
        k4 = state_derivative(c, Y + dt * k3, M_d, M_h)
        Y_new = Y + h6 * (k1 + 2.0 * (k2 + k3) + k4)
        Y = Y_new if alive.all() else np.where(alive, Y_new, Y)
        ring[(k + 1 + n) % (n + 1)] = Y
    steps = np.arange(0, N + 1, stride)
    return BatchRun(t=steps * dt, y=out_y, M_d=out_d, M_h=out_h, v_ref=tab["v_plan"][steps][:, grp],
                    fell=~alive, t_fall=t_fall)
