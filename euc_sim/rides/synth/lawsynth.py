"""Rides with a concealed firmware balance law, written as real logs are written.

:func:`law_ride` rides a speed profile in closed loop under a known motor law
(:data:`LAW`); :func:`eucworld_log` and :func:`wheellog_log` write it as those apps do
(irregular stamps, quantised pitch with a brand's sign and mounting offset, noisy
current or torque).  The truth is never written beside the log; :func:`draw_law` draws a
concealed law for the blind study.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from euc_sim.controllers.motor import MotorPD
from euc_sim.model.parameters import TABLE3
from euc_sim.simulation.engine import default_rider, simulate
from euc_sim.simulation.maneuvers import Maneuver

#: The concealed law: PD gains, tilt-back 2° reached 10 km/h above its 30 km/h onset, a limit.
LAW = {"Kp": 2000.0, "Kd": 200.0, "tiltback_speed": 30.0 / 3.6,
       "tiltback_gain": math.radians(2.0) / (10.0 / 3.6), "torque_limit": 45.0}
#: Torque constant of the written phase current, N·m/A.
K_T = 1.6
#: The rider: reaction delay, s, and motor noise, N·m.
RIDER = {"delay": 0.2, "noise_std": 5.0}
#: Body drag and rolling resistance of the simulated ride.
ROAD = {"aerodynamic_drag": 0.3, "rolling_resistance": 0.01}

EW_HEADER = "datetime,speed,voltage,current,current_phase,power,safety_margin,battery,tilt,roll,extra"
WL_HEADER = ("date,time,latitude,longitude,gps_speed,gps_alt,gps_heading,gps_distance,speed,"
             "voltage,phase_current,torque,pwm,current,power,battery_level,distance,totaldistance,"
             "system_temp,temp2,tilt,roll,mode,alert")


def draw_law(rng: np.random.Generator) -> dict[str, float]:
    """A concealed firmware law for the blind study, as :class:`euc_sim.controllers.motor.MotorPD`
    keywords (SI): K_p 1,500-5,000 N·m/rad, K_d 100-400 N·m·s/rad, tilt-back 2° reached
    10 km/h above an onset drawn in 24-34 km/h, a torque limit of 45-70 N·m."""
    onset = float(rng.uniform(24.0, 34.0)) / 3.6
    return {"Kp": float(rng.uniform(1500.0, 5000.0)), "Kd": float(rng.uniform(100.0, 400.0)),
            "tiltback_speed": onset, "tiltback_gain": math.radians(2.0) / (10.0 / 3.6),
            "torque_limit": float(rng.uniform(45.0, 70.0))}


def profile(seed: int, duration: float) -> tuple[np.ndarray, np.ndarray]:
    """A speed plan 0 → about 45 km/h and back on a 0.5 s grid: (t s, v m/s), 0 at both ends
    (20 s ramps), sine phases from ``seed``.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 0.5)
    v = np.zeros_like(t)
    for f, amp in ((0.004, 3.0), (0.011, 2.0), (0.03, 2.0), (0.07, 1.2)):
        v += amp * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
    env = np.clip(t / 20.0, 0, 1) * np.clip((duration - t) / 20.0, 0, 1)
    return t, env * np.clip(7.5 + v, 0.5, 12.5)


def law_ride(seed: int = 1, duration: float = 300.0, law=LAW) -> pd.DataFrame:
    """The closed-loop ride at 1 kHz under the concealed ``law`` (MotorPD keywords, SI):
    ``t`` s, ``x_dot`` m/s, ``gamma`` rad, ``gamma_dot`` rad/s, ``M_d`` N·m; FallError if the
    rider falls.
    """
    motor = MotorPD(**law)
    rider = default_rider(TABLE3, motor, **RIDER)
    t, v = profile(seed, duration)
    man = Maneuver(name="profile", table=(tuple(t.tolist()), tuple(v.tolist())))
    df = simulate(man, duration, motor=motor, rider=rider, seed=seed, effects=ROAD)
    return df[["t", "x_dot", "gamma", "gamma_dot", "M_d"]]


def _sample(ride: pd.DataFrame, ts: np.ndarray, mean_over: float = 0.2) -> dict[str, np.ndarray]:
    """The wheel's telemetry at times ``ts``: each channel's mean over the ``mean_over`` s
    before (a wheel reports its readings averaged over its telemetry period)."""
    t = ride["t"].to_numpy()
    n = max(1, int(round(mean_over / (t[1] - t[0]))))
    out = {}
    for c in ("x_dot", "gamma", "M_d"):
        x = np.cumsum(np.r_[0.0, ride[c].to_numpy()])
        mean = (x[n:] - x[:-n]) / n                      # mean of the n samples ending at t[k]
        out[c] = np.interp(ts, t[n - 1:], mean)
    return out


def eucworld_log(ride: pd.DataFrame, path: Path, seed: int, sign: int = -1, k_t: float = K_T) -> Path:
    """EUC World CSV at ``path``: irregular 5 Hz rows, pitch in 0.1° steps (``sign``, zero at −2°),
    phase current M_d/``k_t`` in 0.1 A steps with 0.5 A noise (``seed``).
    """
    rng = np.random.default_rng(seed)
    T = float(ride["t"].iloc[-1])
    ts = np.cumsum(rng.uniform(0.18, 0.22, int(T / 0.18)))
    ts = ts[ts < T - 0.5]
    s = _sample(ride, ts)
    tilt = np.round(sign * np.degrees(s["gamma"]) - 2.0, 1)
    I_ph = np.round(s["M_d"] / k_t + rng.normal(0.0, 0.5, ts.size), 1)
    stamps = pd.Timestamp("2025-07-01 10:00:00") + pd.to_timedelta(np.round(ts, 3), unit="s")
    lines = [EW_HEADER]
    for st, v, i, g in zip(stamps, s["x_dot"], I_ph, tilt):
        lines.append(f"{st:%Y-%m-%dT%H:%M:%S}.{st.microsecond // 1000:03d}+0200,{v * 3.6:.2f},"
                     f"84.00,{i * 0.3:.2f},{i:.1f},{84 * i * 0.3:.0f},80,90,{g:.1f},0.0,")
    path.write_text("\n".join(lines) + "\n")
    return path


def wheellog_log(ride: pd.DataFrame, path: Path, seed: int, sign: int = 1) -> Path:
    """WheelLog CSV (newer layout) at ``path``: 0.2 s rows, a third sharing the previous stamp,
    pitch in 0.01° (``sign``, zero at 0.5°), torque in 0.01 N·m with 0.8 N·m noise (``seed``).
    """
    rng = np.random.default_rng(seed)
    T = float(ride["t"].iloc[-1])
    ts = np.arange(0.2, T - 0.5, 0.2)
    s = _sample(ride, ts)
    stamp_t = ts.copy()
    rep = np.flatnonzero(rng.uniform(size=ts.size) < 1 / 3)
    rep = rep[rep > 0]
    stamp_t[rep] = stamp_t[rep - 1]                      # the app's repeated time stamps
    tilt = np.round(sign * np.degrees(s["gamma"]) + 0.5, 2)
    torque = np.round(s["M_d"] + rng.normal(0.0, 0.8, ts.size), 2)
    stamps = pd.Timestamp("2025-07-01 10:00:00") + pd.to_timedelta(np.round(stamp_t, 3), unit="s")
    lines = [WL_HEADER]
    for st, v, q, g in zip(stamps, s["x_dot"], torque, tilt):
        lines.append(f"{st:%Y-%m-%d},{st:%H:%M:%S}.{st.microsecond // 1000:03d},,,,,,,{v * 3.6:.2f},"
                     f"84.00,{q / K_T:.2f},{q:.2f},40,{q / K_T * 0.3:.2f},{84 * q / K_T * 0.3:.0f},"
                     f"90,0,0,30,30,{g:.2f},0.00,0,")
    path.write_text("\n".join(lines) + "\n")
    return path
