"""Synthetic EUC World ride logs with a known total mass and drivetrain (the twin).

:func:`drive_log` writes an EUC World CSV whose battery current, voltage and
safety margin follow :mod:`euc_sim.rides.drive.mass` and :mod:`euc_sim.rides.drive.drivetrain`'s
models with the constants in ``DRIVE``: rolling and drag, copper loss in the
phase current squared (the phase current proportional to the wheel's force),
a constant drain, a Thevenin battery and a PWM from back-EMF plus resistive
drop.  Rows at irregular 0.15-0.25 s intervals with repeated stamps,
speed in km/h at 0.01 resolution, GPS speed reading ``1/scale`` of the wheel's.
With ``road`` the ride climbs a known hill: the climb m·g·v·sin α enters the force
and GPS altitude is the road's, with metre errors (:func:`_gps_altitude`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from ridesynth import ar1_noise

HEADER = ("datetime,speed,voltage,current,current_phase,power,safety_margin,battery,tilt,roll,"
          "gps_lat,gps_lon,gps_speed,gps_alt,extra")

DRIVE = {"mass": 112.0, "c1": 60.0, "c3": 0.30, "P0": 40.0, "R_w": 0.15, "amp_per_N": 0.13,
         "E0": 84.0, "k_Q": 1.5, "R_int": 0.15, "K_v": 6.0, "r_F": 0.01, "scale": 0.95}


def _speed(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Speeds 0-10 m/s with accelerations of a few seconds, stops at both ends."""
    v = np.zeros_like(t)
    for f, amp in ((0.009, 2.5), (0.031, 1.5), (0.083, 0.9), (0.21, 0.35)):
        v += amp * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
    T = t[-1]
    env = np.clip(t / 15.0, 0, 1) * np.clip((T - t) / 15.0, 0, 1)
    return env * (5.5 + v)


def _gps_altitude(seed: int, t: np.ndarray, altitude: np.ndarray, alt_sd: float) -> np.ndarray:
    """GPS altitude, m: the road's plus slow errors (AR(1), 10 s) of ``alt_sd`` m, 0.1 m steps.

    Its own generator (seeded by ``seed``), so the ride's other draws do not move.
    """
    rng = np.random.default_rng([seed, 1])
    rho = math.exp(-float(np.median(np.diff(t))) / 10.0)
    return np.round(altitude + ar1_noise(rng, t.size, alt_sd, rho), 1)


def drive_log(path: Path, seed: int, duration: float = 600.0, truth=DRIVE, signed: bool = True,
              noise_w: float = 30.0, gps: bool = True, phase: bool = True, road=None,
              alt_sd: float = 1.0, signed_phase: bool = False) -> Path:
    """Write the twin ride; returns ``path``.

    True speed v; the wheel logs v/scale.  Force F = m·a + c1 + c3·v² (+ m·g·sin α
    on a ``road``), mechanical power D = F·v; phase current I_ph = amp_per_N·|F|; battery
    P = D + R_w·I_ph² + P0 (regeneration where negative);
    V = E0 − k_Q·Q − R_int·I; duty d = (K_v·v_wheel + r_F·F)/V with
    F = P/v_wheel; EUC World's safety margin = 100 − 100·d.

    ``signed_phase``: the phase current logged as amp_per_N·F (negative when
    braking), not its magnitude.

    ``road``: a function of the distance ridden s (m) giving (sin α, altitude m); the
    GPS altitude is then the altitude with ``alt_sd`` m of slow error (else a flat
    50.0 m, and the output is as without these options).
    """
    rng = np.random.default_rng(seed)
    dt = 0.01
    tf = np.arange(0.0, duration, dt)
    v = _speed(tf, rng)
    a = np.gradient(v, tf)
    F = truth["mass"] * a + truth["c1"] + truth["c3"] * v ** 2
    alt = np.full_like(tf, 50.0)
    if road is not None:
        sin_a, h = road(np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)]))
        F = F + truth["mass"] * 9.81 * sin_a
        alt = _gps_altitude(seed, tf, h, alt_sd)
    Iph = truth["amp_per_N"] * (F if signed_phase else np.abs(F))
    P = F * v + truth["R_w"] * Iph ** 2 + truth["P0"]
    rho = math.exp(-dt / 0.3)
    P = P + ar1_noise(rng, tf.size, noise_w, rho)
    # battery: solve V = E - R·P/V for V (positive root), coulomb-count Q
    V = np.full_like(P, truth["E0"])
    Q = 0.0
    for i in range(P.size):
        E = truth["E0"] - truth["k_Q"] * Q
        V[i] = 0.5 * (E + math.sqrt(max(E * E - 4 * truth["R_int"] * P[i], 1.0)))
        Q += P[i] / V[i] * dt / 3600.0
    I = P / V
    v_wheel = v / truth["scale"]
    Fb = np.where(v_wheel > 0.5, P / np.maximum(v_wheel, 0.5), 0.0)
    duty = np.clip((truth["K_v"] * v_wheel + truth["r_F"] * Fb) / V
                   + rng.normal(0, 0.01, V.size), 0, 1)        # a reading with 1 point of noise
    ts = np.cumsum(rng.uniform(0.15, 0.25, int(duration / 0.15)))
    ts = ts[ts < duration - 0.5]
    pick = lambda x: np.interp(ts, tf, x)   # noqa: E731
    vs, Vs, Is, ds, vt, ph = pick(v_wheel), pick(V), pick(I), pick(duty), pick(v), pick(Iph)
    hs = pick(alt)
    if not signed:
        Is = np.abs(Is)
    stamps = pd.Timestamp("2025-07-01 10:00:00") + pd.to_timedelta(np.round(ts, 3), unit="s")
    rows = []
    for k, (s, vv, vo, cu, d, g, i_ph, h) in enumerate(zip(stamps, vs, Vs, Is, ds, vt, ph, hs)):
        gps_cells = (f"48.1,-1.7,{g * 3.6:.2f},{h:.1f}" if gps and k % 5 == 0 else ",,,")
        rows.append(f"{s:%Y-%m-%dT%H:%M:%S}.{s.microsecond // 1000:03d}+0200,{vv * 3.6:.2f},"
                    f"{vo:.2f},{cu:.2f},{f'{i_ph:.2f}' if phase else ''},{vo * cu:.0f},{100 - 100 * d:.1f},90,,,"
                    f"{gps_cells},euc.distance=0")
    for i in rng.choice(np.arange(10, len(rows) - 10), 4, replace=False):
        rows.insert(i, rows[i])
    path.write_text(HEADER + "\n" + "\n".join(rows) + "\n")
    return path
