"""Synthetic motion capture: a simulated run sampled like the paper's OptiTrack data.

120 Hz with the paper's ±0.20 mm and ±0.5° taken as one standard deviation of Gaussian
noise (:data:`NOISE_LEVELS`).  Columns (:data:`RECORDING_COLUMNS`): ``t, x, gamma, phi,
psi, theta``, the held ``M_d, M_h`` unless hidden, and the markers C, E (0.42 m above C)
and G, m, ground frame, by eqs. (1)-(2).  Angles get angle noise, C, E and x position
noise, and G sits at A + h(sin φ_rec, ·, cos φ_rec) with the recorded φ plus position
noise.  States by cubic Hermite interpolation, torques by zero-order hold;
``sensor_time_offset`` τ delays φ and G: φ_rec(t) = φ(t − τ).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np
import pandas as pd

from euc_sim.errors import InputError
from euc_sim.model.parameters import Params

__all__ = ["RATE", "E_HEIGHT", "NOISE_LEVELS", "RECORDING_COLUMNS", "sample_times",
           "motion_capture"]

#: Motion-capture sampling rate, Hz (the paper's OptiTrack).
RATE = 120.0
#: Distance C–E along the EUC body axis, m (the MJCF site ``E``).
E_HEIGHT = 0.42
#: 1-sigma noise: (position m, angle rad).
NOISE_LEVELS = {"paper": (0.20e-3, math.radians(0.5)), "none": (0.0, 0.0)}
RECORDING_COLUMNS = ("t", "x", "gamma", "phi", "psi", "theta", "M_d", "M_h",
                     "C_X", "C_Y", "C_Z", "E_X", "E_Y", "E_Z", "G_X", "G_Y", "G_Z")


def sample_times(duration: float, rate: float = RATE) -> np.ndarray:
    """k / rate for k = 0 … ⌊duration·rate⌋, s (strictly increasing)."""
    n = int(math.floor(duration * rate + 1e-9))
    return np.arange(n + 1) / rate


def _hermite(t_src, y, ydot, t):
    from scipy.interpolate import CubicHermiteSpline

    return CubicHermiteSpline(t_src, y, ydot)(t)


def _rotate(psi, theta, r):
    """T_ψ T_ϑ r of eqs. (1)-(2), r of shape (N, 3)."""
    cp, sp, ct, st = np.cos(psi), np.sin(psi), np.cos(theta), np.sin(theta)
    rx, ry, rz = r[:, 0], r[:, 1], r[:, 2]
    ry2 = ct * ry - st * rz                     # T_ϑ: about the x axis
    rz2 = st * ry + ct * rz
    return np.column_stack([cp * rx - sp * ry2, sp * rx + cp * ry2, rz2])


def motion_capture(run: pd.DataFrame, params: Params, *, noise: str = "paper", seed: int = 0,
                   effects: Mapping[str, float] | None = None, hide_torques: bool = False) -> pd.DataFrame:
    """Sample a simulated run at :data:`RATE` with seeded noise, in CONTRACT's columns.

    Parameters
    ----------
    run : pandas.DataFrame
        Output of :func:`euc_sim.simulation.engine.simulate`.
    params : Params
        The true parameters (R, l0 and h place C and G).
    noise : {"paper", "none"} or (float, float)
        A level of :data:`NOISE_LEVELS` or (position σ [m], angle σ [rad]).
    seed : int
        Seed of the measurement noise.
    effects : mapping, optional
        Only ``sensor_time_offset`` (s) acts here.
    hide_torques : bool
        Leave out M_d and M_h.

    Raises
    ------
    ValueError
        For an unknown noise level or a run without the needed columns.
    """
    if isinstance(noise, str) and noise not in NOISE_LEVELS:
        raise InputError(f"unknown noise level {noise!r}; valid: {', '.join(NOISE_LEVELS)}")
    need = ("t", "x", "gamma", "phi", "x_dot", "gamma_dot", "phi_dot", "M_d", "M_h")
    missing = [c for c in need if c not in run.columns]
    if missing:
        raise ValueError(f"run is missing columns {', '.join(missing)}")
    sig_pos, sig_ang = NOISE_LEVELS[noise] if isinstance(noise, str) else (float(v) for v in noise)
    tau = float(dict(effects or {}).get("sensor_time_offset", 0.0))
    ts = run["t"].to_numpy()
    t = sample_times(float(ts[-1]))
    n = len(t)
    x = _hermite(ts, run["x"].to_numpy(), run["x_dot"].to_numpy(), t)
    gamma = _hermite(ts, run["gamma"].to_numpy(), run["gamma_dot"].to_numpy(), t)
    phi_lag = _hermite(ts, run["phi"].to_numpy(), run["phi_dot"].to_numpy(), np.clip(t - tau, 0.0, None))
    if "psi" in run.columns:
        psi = np.interp(t, ts, run["psi"].to_numpy())
        theta = np.interp(t, ts, run["theta"].to_numpy())
    else:
        psi = theta = np.zeros(n)
    h = np.interp(t, ts, run["h"].to_numpy()) if "h" in run.columns else np.full(n, params.h)
    zoh = np.minimum(np.searchsorted(ts, t + 1e-9, side="right") - 1, len(ts) - 1)

    rng = np.random.default_rng([int(seed), 120])
    ang = lambda: rng.normal(0.0, sig_ang, n) if sig_ang else np.zeros(n)          # noqa: E731
    pos = lambda: rng.normal(0.0, sig_pos, (n, 3)) if sig_pos else np.zeros((n, 3))  # noqa: E731
    psi_m, theta_m, gamma_m, phi_m = psi + ang(), theta + ang(), gamma + ang(), phi_lag + ang()
    x_m = x + (rng.normal(0.0, sig_pos, n) if sig_pos else 0.0)

    # the ground path of the contact point P: x runs along it, heading psi
    dt_src = np.diff(ts)
    run_psi = run["psi"].to_numpy() if "psi" in run.columns else np.zeros(len(ts))
    vx = run["x_dot"].to_numpy()
    def path(f):
        # trapezoidal integral of the ground velocity, sampled by cubic Hermite with that
        # velocity as its slope: linear interpolation would put corners in the path and
        # millimetre-per-second² errors into the Section 2 acceleration
        g = vx * f(run_psi)
        s = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * dt_src)])
        return _hermite(ts, s, g, t)
    if "psi" in run.columns:
        X = path(np.cos) + float(run["x"].iloc[0])
        Y = path(np.sin)
    else:                       # straight running: the path is x itself
        X, Y = x.copy(), np.zeros(n)
    P = np.column_stack([X, Y, np.zeros(n)])
    up = lambda a: np.column_stack([np.sin(a), np.zeros(n), np.cos(a)])          # noqa: E731
    C = P + _rotate(psi, theta, np.column_stack([np.zeros(n), np.zeros(n), np.full(n, params.R)]))
    E = C + _rotate(psi, theta, E_HEIGHT * up(gamma))
    A_off = -params.l0 * up(gamma)
    G = C + _rotate(psi, theta, A_off + h[:, None] * up(phi_m))
    C_m, E_m, G_m = C + pos(), E + pos(), G + pos()

    cols = {"t": t, "x": x_m, "gamma": gamma_m, "phi": phi_m, "psi": psi_m, "theta": theta_m}
    if not hide_torques:
        cols["M_d"] = run["M_d"].to_numpy()[zoh]
        cols["M_h"] = run["M_h"].to_numpy()[zoh]
    for name, arr in (("C", C_m), ("E", E_m), ("G", G_m)):
        for i, axis in enumerate("XYZ"):
            cols[f"{name}_{axis}"] = arr[:, i]
    return pd.DataFrame(cols)
