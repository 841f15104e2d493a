"""Synthetic WheelLog ride logs with known physics, shared by the ride tests.

:func:`synth_log` writes an old-layout WheelLog CSV whose battery power follows
:mod:`euc_sim.rides.balance.design`'s energy balance with known C_rr, k, k_cu and P₀ (``TRUTH``),
plus correlated noise, irregular rows, repeated time stamps and one gap.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from euc_sim.rides.grids.signals import RideAssumptions

OLD_HEADER = ("date,time,speed,voltage,current,power,battery_level,distance,totaldistance,"
              "system_temp,cpu_temp,tilt,roll,mode,alert")

A = RideAssumptions()
MG = A.total_mass * A.g

TRUTH = {"copper_loss": 0.01, "rolling_resistance": 0.015,
         "aerodynamic_drag": 0.35, "drivetrain_idle_loss": 20.0}


def battery_power(v: np.ndarray, a: np.ndarray, truth=TRUTH, slope: float = 0.0) -> np.ndarray:
    """The energy balance's battery power, W: P₀ + D + k_cu·(m_eq·a)² in both regimes,
    D = m_eq·a·v + C_rr·m·g·|v| + k·|v|³ + m·g·slope·v."""
    D = (A.m_eq * a * v + truth["rolling_resistance"] * MG * np.abs(v)
         + truth["aerodynamic_drag"] * np.abs(v) ** 3 + MG * slope * v)
    return truth["drivetrain_idle_loss"] + D + truth.get("copper_loss", 0.0) * (A.m_eq * a) ** 2



def ar1_noise(rng: np.random.Generator, n: int, sigma: float, rho: float) -> np.ndarray:
    """Stationary AR(1) noise of standard deviation ``sigma`` (W) and lag-one correlation ``rho``."""
    from scipy.signal import lfilter

    w = rng.normal(0, sigma * math.sqrt(1 - rho ** 2), n)
    return lfilter([1.0], [1.0, -rho], w)

def _speed(t: np.ndarray, rng: np.random.Generator, backwards: bool) -> np.ndarray:
    """A smooth ride: stops at both ends, speeds 0-8 m/s (and some reversing)."""
    ph = rng.uniform(0, 2 * np.pi, 4)
    base = (4.0 + 2.5 * np.sin(2 * np.pi * 0.011 * t + ph[0])
            + 1.3 * np.sin(2 * np.pi * 0.047 * t + ph[1])
            + 0.7 * np.sin(2 * np.pi * 0.13 * t + ph[2]))
    if backwards:
        base = base - 3.5
    T = t[-1]
    env = 0.5 * (1 - np.cos(np.pi * np.clip(t / 20.0, 0, 1))) * \
        0.5 * (1 - np.cos(np.pi * np.clip((T - t) / 20.0, 0, 1)))
    v = np.log1p(np.exp(3.0 * base)) / 3.0 if not backwards else base
    return env * v


def synth_log(path: Path, seed: int, duration: float = 300.0, truth=TRUTH, slope: float = 0.0,
              noise_w: float = 40.0, backwards: bool = False, gap_at: float | None = 150.0,
              repeats: int = 5) -> Path:
    """Write a WheelLog (old layout) CSV of a ride with known physics.

    Battery power :func:`battery_power` (P₀ + D + k_cu·(m_eq·a)²), plus AR(1) noise of std ``noise_w`` W and 0.3 s
    correlation; rows at irregular 0.1-0.3 s intervals, ``repeats`` repeated
    time stamps, one 2 s gap; speed rounded to 0.01 km/h like the app.
    """
    rng = np.random.default_rng(seed)
    tf = np.arange(0.0, duration, 0.01)
    v = _speed(tf, rng, backwards)
    a = np.gradient(v, tf)
    P = battery_power(v, a, truth, slope)
    rho = math.exp(-0.01 / 0.3)
    P = P + ar1_noise(rng, tf.size, noise_w, rho)
    ts = np.cumsum(rng.uniform(0.1, 0.3, int(duration / 0.1)))
    ts = ts[ts < duration - 0.5]
    if gap_at is not None:
        ts = ts[(ts < gap_at) | (ts > gap_at + 2.0)]
    vs = np.interp(ts, tf, v)
    Ps = np.interp(ts, tf, P)
    volt = 65.0 + rng.normal(0, 0.05, ts.size)
    cur = Ps / volt
    stamps = pd.Timestamp("2024-06-01 10:00:00") + pd.to_timedelta(np.round(ts, 3), unit="s")
    rows = []
    for s, vv, vo, cu in zip(stamps, vs, volt, cur):
        rows.append(f"{s:%Y-%m-%d},{s:%H:%M:%S}.{s.microsecond // 1000:03d},{vv * 3.6:.2f},"
                    f"{vo:.2f},{cu:.2f},{vo * cu:.2f},90,0,1000,30,0,0.00,0.00,0,")
    for i in rng.choice(np.arange(10, len(rows) - 10), repeats, replace=False):
        rows.insert(i, rows[i])          # the app sometimes writes a row twice
    path.write_text(OLD_HEADER + "\n" + "\n".join(rows) + "\n")
    return path
