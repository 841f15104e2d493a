"""Synthetic WheelLog (newer layout) logs with known summary figures, for the summary tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

HEADER = ["date", "time", "latitude", "longitude", "gps_speed", "gps_alt", "gps_heading",
          "gps_distance", "speed", "voltage", "phase_current", "current", "power", "torque", "pwm",
          "battery_level", "distance", "totaldistance", "system_temp", "temp2", "tilt", "roll",
          "mode", "alert"]
LAT0, LON0 = 48.0, 2.0
M_PER_DEG_LAT = 6_371_000.0 * np.pi / 180.0


def synth_summary_log(path: Path, *, rate: float = 5.0, ride_s: float = 600.0, rest_s: float = 20.0,
                      speed_kmh: float = 25.0, volt: float = 80.0, amps: float = 10.0,
                      regen_amps: float = 0.0, gps: bool = True, gap: tuple | None = None,
                      pwm_peak: tuple = (300.0, 72.5), alarm_rows: tuple = (),
                      battery: tuple = (90.0, 60.0), sag_pct_per_amp: float = 0.5,
                      R_int: float = 0.0, temp_C: float = 30.0, amps_wave: float = 0.0,
                      ocv_per_Ah: float = 0.0, start: str = "2024-06-01 10:00:00", seed: int = 0) -> Path:
    """Write a log: ``rest_s`` standing, ``ride_s`` at constant speed due north, ``rest_s`` standing.

    Current is ``amps`` while riding (``regen_amps`` negative over the last 60 s of the ride),
    0.2 A at rest; the battery reading falls linearly from ``battery[0]`` to ``battery[1]``
    over the ride and sags by ``sag_pct_per_amp`` per ampere; voltage ``volt - R_int·I``.
    ``gap`` = (t, length) removes the rows of that stretch (the wheel keeps riding).
    ``amps_wave`` modulates the riding current by that share (a 20 s sine); the open-circuit
    voltage falls by ``ocv_per_Ah`` V per ampere-hour drawn.
    """
    rng = np.random.default_rng(seed)
    T = 2 * rest_s + ride_s
    t = np.arange(0.0, T + 1e-9, 1.0 / rate)
    riding = (t >= rest_s) & (t < rest_s + ride_s)
    v = np.where(riding, speed_kmh, 0.0)
    cur = np.where(riding, amps * (1 + amps_wave * np.sin(2 * np.pi * t / 20.0)), 0.2)
    if regen_amps:
        cur = np.where(riding & (t >= rest_s + ride_s - 60.0), -regen_amps, cur)
    frac = np.clip((t - rest_s) / ride_s, 0, 1)
    bat = battery[0] + (battery[1] - battery[0]) * frac - sag_pct_per_amp * np.abs(cur)
    dist = np.cumsum(np.r_[0.0, np.diff(t)] * v / 3.6)
    pwm = np.where(riding, 40.0, 0.0)
    pwm[np.argmin(np.abs(t - pwm_peak[0]))] = pwm_peak[1]
    alert = np.array([""] * t.size, dtype=object)
    for i in alarm_rows:
        alert[i] = "speed"
    Q = np.cumsum(cur * np.r_[0.0, np.diff(t)]) / 3600.0
    V = volt - ocv_per_Ah * Q - R_int * cur + rng.normal(0, 1e-3, t.size)
    df = pd.DataFrame({
        "date": pd.Timestamp(start).strftime("%Y-%m-%d"),
        "time": (pd.Timestamp(start) + pd.to_timedelta(t, unit="s")).strftime("%H:%M:%S.%f").str[:-3],
        "latitude": LAT0 + dist / M_PER_DEG_LAT if gps else "", "longitude": LON0 if gps else "",
        "gps_speed": v if gps else "", "gps_alt": "", "gps_heading": "", "gps_distance": "",
        "speed": v, "voltage": V, "phase_current": cur * 2, "current": cur, "power": V * cur,
        "torque": 0, "pwm": pwm, "battery_level": np.round(bat, 1), "distance": np.round(dist),
        "totaldistance": 100000 + np.round(dist), "system_temp": temp_C, "temp2": temp_C,
        "tilt": 0, "roll": 0, "mode": 0, "alert": alert})
    if gap is not None:
        df = df[(t < gap[0]) | (t >= gap[0] + gap[1])]
    df[HEADER].to_csv(path, index=False)
    return path


def as_layout(src: Path, dst: Path, layout: str) -> Path:
    """Rewrite a :func:`synth_summary_log` file in the EUC World or DarknessBot layout."""
    df = pd.read_csv(src, dtype=str, keep_default_na=False)
    stamp = pd.to_datetime(df["date"] + " " + df["time"])
    num = lambda c: pd.to_numeric(df[c], errors="coerce")     # noqa: E731
    if layout == "eucworld":
        out = pd.DataFrame({
            "datetime": stamp.dt.strftime("%Y-%m-%dT%H:%M:%S.%f").str[:-3] + "+0200",
            "distance": num("distance") / 1000, "distance_total": num("totaldistance") / 1000,
            "speed": df["speed"], "voltage": df["voltage"], "current": df["current"],
            "current_phase": "", "power": df["power"], "battery": df["battery_level"],
            "temp": df["system_temp"], "safety_margin": 100 - num("pwm"), "tilt": "", "roll": "",
            "alarm": np.where(df["alert"] != "", 1, 0), "gps_lat": df["latitude"],
            "gps_lon": df["longitude"], "gps_speed": df["gps_speed"], "gps_alt": "", "extra": ""})
    else:
        out = pd.DataFrame({
            "Date": stamp.dt.strftime("%d.%m.%Y %H:%M:%S.%f").str[:-3], "Speed": df["speed"],
            "Voltage": df["voltage"], "PWM": df["pwm"], "Current": df["current"], "Power": df["power"],
            "Battery level": df["battery_level"], "Total mileage": num("totaldistance") / 1000,
            "Temperature": df["system_temp"], "Pitch": 0, "Roll": 0, "Latitude": df["latitude"],
            "Longitude": df["longitude"], "Altitude": ""})
    out.to_csv(dst, index=False)
    return dst
