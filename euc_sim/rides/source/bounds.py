"""The physical range of every ride-log channel, and what the reader does with values outside it.

:data:`CHANNEL_BOUNDS` is in the units a person reads a log in (km/h, V, A, %, degrees);
no shared ride has a value outside it.  :func:`bound_channel`: a few values outside
(:data:`FEW` of them or :data:`FEW_ROWS` rows) are repaired and said (speed rows dropped,
other cells emptied); more refuse the log (another quantity, other units or a broken
logger).  :func:`speed_sign` refuses a log whose moving speeds are mostly negative and
turns isolated sign flips back.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["CHANNEL_BOUNDS", "FEW", "FEW_ROWS", "MAX_ROWS", "bound_channel", "speed_sign"]

#: Most data rows a log may have: ten times 90 min at the fastest logger's 37 Hz (1.2 GB read).
MAX_ROWS = 2_000_000

#: Fraction of a channel's values that may lie out of range and be repaired (dropped or
#: emptied, said); beyond it the log is refused.
FEW = 0.01
#: ... or this many rows, whichever is more (a short log's one glitch is still a glitch).
FEW_ROWS = 5

#: Canonical channel -> (low, high, unit shown, SI per shown unit).
CHANNEL_BOUNDS: dict[str, tuple[float, float, str, float]] = {
    "v": (-150.0, 150.0, "km/h", 1 / 3.6),
    "voltage": (0.0, 200.0, "V", 1.0),
    "current": (-500.0, 500.0, "A", 1.0),
    "phase_current": (-1000.0, 1000.0, "A", 1.0),
    "power": (-100e3, 100e3, "W", 1.0),
    "torque": (-1000.0, 1000.0, "N·m", 1.0),
    "pwm": (0.0, 110.0, "%", 1.0),
    "safety_margin": (-10.0, 100.0, "%", 1.0),
    "battery": (0.0, 100.0, "%", 1.0),
    "distance": (-1e7, 1e7, "m", 1.0),
    "total_distance": (0.0, 1e9, "m", 1.0),
    "temperature": (-60.0, 200.0, "°C", 1.0),
    "temperature2": (-60.0, 200.0, "°C", 1.0),
    "tilt": (-180.0, 180.0, "°", math.pi / 180),
    "roll": (-180.0, 180.0, "°", math.pi / 180),
    "latitude": (-90.0, 90.0, "°", 1.0),
    "longitude": (-180.0, 180.0, "°", 1.0),
    "gps_speed": (0.0, 150.0, "km/h", 1 / 3.6),
    "gps_alt": (-500.0, 9000.0, "m", 1.0),
    "gps_heading": (-360.0, 360.0, "°", math.pi / 180),
    "gps_distance": (0.0, 1e7, "m", 1.0),
}

#: Speeds below this, m/s, are not tested for a sign (standing, rolling back a little).
MOVING = 1.0


def _allowed(n: int) -> int:
    return max(FEW_ROWS, int(FEW * n))


def bound_channel(name: str, column: str, values: np.ndarray, refuse, repairs: list[str]):
    """The channel's values with the out-of-range ones handled (module docstring).

    Parameters
    ----------
    name, column : str
        Canonical channel (a key of :data:`CHANNEL_BOUNDS`); the file's column, for messages.
    values : numpy.ndarray
        SI units, NaN for empty cells; row ``i`` is line ``i + 2``.
    refuse : callable
        ``refuse(message, column=, line=)`` → the exception refusing the log (LogFormatError).
    repairs : list of str
        A repair's sentence is appended here.

    Returns
    -------
    values, keep : numpy.ndarray
        Out-of-range cells emptied (NaN), except for the speed ``v`` whose bad rows get
        ``keep`` False instead.
    """
    lo, hi, unit, si = CHANNEL_BOUNDS[name]
    shown = values / si
    with np.errstate(invalid="ignore"):
        bad = np.isfinite(shown) & ((shown < lo) | (shown > hi)) | np.isinf(shown)
    keep = np.ones(values.size, bool)
    n_bad = int(bad.sum())
    if not n_bad:
        return values, keep
    i = int(np.flatnonzero(bad)[0])
    span = f"[{lo:g}, {hi:g}] {unit}"
    n = int(np.isfinite(values).sum() + np.isinf(values).sum())
    if n_bad > _allowed(n):
        raise refuse(f"{n_bad} of {n} values outside {span} (first {shown[i]:.4g} {unit}): "
                                   f"not this channel's quantity or units; the log is refused",
                             column=column, line=i + 2)
    what = "rows dropped" if name == "v" else "cells emptied (the rows kept)"
    repairs.append(f"{column}: {n_bad} value(s) outside {span}, first {shown[i]:.4g} {unit} at line "
                   f"{i + 2}; {what}")
    if name == "v":
        return values, ~bad
    out = values.copy()
    out[bad] = np.nan
    return out, keep


def speed_sign(v: np.ndarray, t: np.ndarray, column: str, refuse, repairs: list[str]) -> np.ndarray:
    """The speed (m/s, rows in time order, stamps ``t`` in s) with isolated sign flips undone.

    ``refuse`` and ``repairs`` as for :func:`bound_channel`; refused when most moving speeds
    are negative or more than a few rows are flips.
    """
    moving = np.abs(v) > MOVING
    neg = moving & (v < 0)
    if neg.sum() > 0.5 * moving.sum() > 0:
        i = int(np.flatnonzero(neg)[0])
        raise refuse(f"{int(neg.sum())} of {int(moving.sum())} moving speeds are negative "
                                   f"(first {v[i] * 3.6:.4g} km/h at t = {t[i]:.1f} s): the speed's sign "
                                   f"is reversed or the column is no speed; a ride's speed is forward, positive",
                             column=column)
    if v.size < 3:
        return v
    mid, before, after = v[1:-1], v[:-2], v[2:]
    near = np.abs(-mid - 0.5 * (before + after)) <= 0.25 * np.abs(mid) + 0.5
    flip = np.r_[False, (mid < -MOVING) & (before > 0) & (after > 0) & near, False]
    n = int(flip.sum())
    if not n:
        return v
    i = int(np.flatnonzero(flip)[0])
    if n > _allowed(int(moving.sum())):
        raise refuse(f"{n} of {int(moving.sum())} moving rows have their speed's sign flipped "
                                   f"(−v between neighbours near +v; first {v[i] * 3.6:.4g} km/h at t = "
                                   f"{t[i]:.1f} s), more than {FEW:.0%}: the speed column is not to be trusted",
                             column=column)
    repairs.append(f"{column}: {n} isolated sign flip(s) (a row at −v between neighbours near +v), first "
                   f"{v[i] * 3.6:.4g} km/h at t = {t[i]:.1f} s; turned back to +v")
    out = v.copy()
    out[flip] = -out[flip]
    return out
