"""One synthetic ride written in each log layout ``euc-sim ride`` reads.

:func:`layout_log` writes the same ride (:mod:`ridesynth`'s battery-power physics, a pitch
that follows the acceleration, a duty from back-EMF, GPS every fifth row) as EUC World,
WheelLog (old and new layout) or DarknessBot write it: their columns, units and time stamps
as :mod:`euc_sim.rides.source.logs` documents them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from ridesynth import OLD_HEADER, _speed, ar1_noise, battery_power

LAYOUTS = ("eucworld", "wheellog_old", "wheellog_new", "darknessbot")

EW_HEADER = ("datetime,speed,voltage,current,current_phase,power,safety_margin,battery,distance,"
             "tilt,roll,gps_lat,gps_lon,gps_speed,gps_alt")
WL_NEW_HEADER = ("date,time,latitude,longitude,gps_speed,gps_alt,gps_heading,gps_distance,speed,"
                 "voltage,phase_current,current,power,torque,pwm,battery_level,distance,"
                 "totaldistance,system_temp,temp2,tilt,roll,mode,alert")
DB_HEADER = ("Date,Speed,Voltage,PWM,Current,Power,Battery level,Total mileage,Temperature,"
             "Pitch,Roll,Latitude,Longitude,Altitude")


def ride_rows(seed: int, duration: float) -> pd.DataFrame:
    """The ride at irregular 0.08-0.12 s rows (enough riding rows in a minute for the balance
    law's fit): ``t`` s, ``v`` m/s, ``V`` V, ``I`` A, ``P`` W,
    ``I_ph`` A, ``pwm`` %, ``pitch`` degrees, ``dist`` m, ``gps`` (bool: a fix on this row)."""
    rng = np.random.default_rng(seed)
    tf = np.arange(0.0, duration, 0.01)
    v = _speed(tf, rng, backwards=False)
    a = np.gradient(v, tf)
    P = battery_power(v, a)
    P = P + ar1_noise(rng, tf.size, 30.0, math.exp(-0.01 / 0.3))
    ts = np.cumsum(rng.uniform(0.08, 0.12, int(duration / 0.08)))
    ts = ts[ts < duration - 0.5]
    pick = lambda x: np.interp(ts, tf, x)   # noqa: E731
    vs, Ps, acc = pick(v), pick(P), pick(a)
    V = 84.0 - 0.002 * np.cumsum(Ps) * np.diff(ts, prepend=0.0) / 3600.0 - 0.1 * Ps / 84.0
    force = Ps / np.maximum(vs, 0.5)
    return pd.DataFrame({
        "t": ts, "v": vs, "V": V, "I": Ps / V, "P": Ps,
        "I_ph": 0.12 * np.abs(force) + rng.normal(0, 0.3, ts.size),
        "pwm": np.clip(100 * (6.0 * vs + 0.01 * force) / V, 0, 100),
        "pitch": np.degrees(0.03 * acc) + rng.normal(0, 0.05, ts.size),
        "dist": np.cumsum(vs * np.diff(ts, prepend=0.0)),
        "gps": np.arange(ts.size) % 5 == 0,
    })


def _stamps(t: np.ndarray) -> pd.DatetimeIndex:
    return pd.Timestamp("2025-06-01 10:00:00") + pd.to_timedelta(np.round(t, 3), unit="s")


def _ms(s: pd.Timestamp) -> str:
    return f"{s:%H:%M:%S}.{s.microsecond // 1000:03d}"


def _eucworld(r: pd.DataFrame) -> list[str]:
    lines = [EW_HEADER]
    for s, x in zip(_stamps(r["t"].to_numpy()), r.itertuples()):
        gps = f"48.1,-1.7,{x.v * 3.6:.2f},50.0" if x.gps else ",,,"
        lines.append(f"{s:%Y-%m-%dT}{_ms(s)}+0200,{x.v * 3.6:.2f},{x.V:.2f},{x.I:.2f},{x.I_ph:.1f},"
                     f"{x.P:.0f},{100 - x.pwm:.1f},90,{x.dist / 1000:.4f},{x.pitch:.1f},0.0,{gps}")
    return lines


def _wheellog_old(r: pd.DataFrame) -> list[str]:
    lines = [OLD_HEADER]
    for s, x in zip(_stamps(r["t"].to_numpy()), r.itertuples()):
        lines.append(f"{s:%Y-%m-%d},{_ms(s)},{x.v * 3.6:.2f},{x.V:.2f},{x.I:.2f},{x.P:.2f},90,"
                     f"{x.dist:.0f},1000,30,0,0.00,0.00,0,")
    return lines


def _wheellog_new(r: pd.DataFrame) -> list[str]:
    lines = [WL_NEW_HEADER]
    for s, x in zip(_stamps(r["t"].to_numpy()), r.itertuples()):
        gps = f"48.1,-1.7,{x.v * 3.6:.2f},50.0,90.0,{x.dist:.0f}" if x.gps else ",,,,,"
        lines.append(f"{s:%Y-%m-%d},{_ms(s)},{gps},{x.v * 3.6:.2f},{x.V:.2f},{x.I_ph:.2f},{x.I:.2f},"
                     f"{x.P:.2f},{x.I_ph * 1.6:.2f},{x.pwm:.2f},90,{x.dist:.0f},1000000,30,30,"
                     f"{x.pitch:.2f},0.00,Drive,")
    return lines


def _darknessbot(r: pd.DataFrame) -> list[str]:
    lines = [DB_HEADER]
    for s, x in zip(_stamps(r["t"].to_numpy()), r.itertuples()):
        gps = "69.65,18.91,50.7" if x.gps else ",,"
        lines.append(f"{s:%d.%m.%Y} {_ms(s)},{x.v * 3.6:.2f},{x.V:.2f},{x.pwm:.1f},{x.I:.2f},"
                     f"{x.P:.1f},90,{1000 + x.dist / 1000:.4f},30.0,{x.pitch:.1f},0.0,{gps}")
    return lines


def layout_log(path: Path, layout: str, seed: int = 5, duration: float = 60.0) -> Path:
    """Write the ride of ``seed`` as ``layout`` (one of :data:`LAYOUTS`); returns ``path``."""
    writer = {"eucworld": _eucworld, "wheellog_old": _wheellog_old,
              "wheellog_new": _wheellog_new, "darknessbot": _darknessbot}[layout]
    path.write_text("\n".join(writer(ride_rows(seed, duration))) + "\n")
    return path
