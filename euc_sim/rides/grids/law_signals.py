"""The riding rows a wheel's balance law is read from: pitch, its rate, speed, acceleration
and motor torque, on the log's own (uneven) time stamps.

The torque is the logged ``torque`` or the phase current times K_t = K_e
(:mod:`euc_sim.rides.drive.drivetrain`).  :func:`law_rows` keeps the riding rows (speed
above :data:`V_MIN`, pitch within :data:`MAX_PITCH` of its riding median) with exact
mean rates over the stamps' intervals, a leaky pitch integral and each channel at the
neighbouring rows (Simpson's weights) for :mod:`euc_sim.rides.law.controller_law`.  An
interval the gap policy splits at breaks every derivative, mean and integral.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from euc_sim.errors import InputError
from euc_sim.rides.grids.spin import spin_rows
from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.rides.source.ride import Ride
from euc_sim.stats import label_rows

__all__ = ["LawUnavailable", "LawRows", "law_rows", "V_MIN", "MAX_PITCH", "MIN_ROWS", "ACCEL_HALF", "INTEGRAL_TAU"]

#: Speed above which a row counts as riding, m/s.
V_MIN = 1.0
#: Pitch farther than this from the riding median is the wheel lying or carried, rad.
MAX_PITCH = math.radians(15.0)
#: Half-span of the acceleration column, s: a set-point follows the ride's acceleration
#: over seconds; the acceleration within one telemetry period is the motor torque's own.
ACCEL_HALF = 1.0
#: Leak of the integral column, s.
INTEGRAL_TAU = 5.0
#: Fewer riding rows than this: too short.
MIN_ROWS = 300


class LawUnavailable(InputError):
    """The log cannot show the wheel's balance law; the message says why, with numbers."""


@dataclass(frozen=True)
class LawRows:
    """The riding rows a law is fitted or scored on.

    Attributes
    ----------
    t : numpy.ndarray
        s.
    tilt, tilt_dot : numpy.ndarray
        Logged pitch (the log's convention), rad, and its rate, rad/s.
    v, a : numpy.ndarray
        Wheel speed m/s, acceleration m/s².
    z : numpy.ndarray
        Leaky integral of (tilt − median riding tilt), rad·s.
    y : numpy.ndarray
        Motor torque N·m, or phase current A without a torque constant (``unit``).
    channel : str
        ``"phase_current"`` or ``"torque"``.
    scale : float
        ``y`` = scale × the logged channel (K_t N·m/A, or 1).
    pitch_step, dt_median : float
        The logged pitch's quantisation, rad; median sample interval, s.
    w3 : numpy.ndarray
        (n, 3) Simpson weights of the previous, this and the next row giving each channel's
        mean over [t₋₁, t₊₁], the interval of the central differences.
    tilt3, v3, z3, y3 : numpy.ndarray
        (n, 3) the channels at the previous, this and the next row.
    """

    t: np.ndarray
    tilt: np.ndarray
    tilt_dot: np.ndarray
    v: np.ndarray
    a: np.ndarray
    z: np.ndarray
    y: np.ndarray
    channel: str
    unit: str
    scale: float
    pitch_step: float
    dt_median: float
    w3: np.ndarray
    tilt3: np.ndarray
    v3: np.ndarray
    z3: np.ndarray
    y3: np.ndarray

    def take(self, idx: np.ndarray) -> "LawRows":
        """The rows ``idx`` (an index or boolean array)."""
        return replace(self, **{k: getattr(self, k)[idx] for k in ("t", "tilt", "tilt_dot", "v", "a", "z", "y",
                                                                   "w3", "tilt3", "v3", "z3", "y3")})


def _rate(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """dx/dt as (x₊₁ − x₋₁)/(t₊₁ − t₋₁), the exact mean rate over [t₋₁, t₊₁], on the
    uneven time stamps; NaN at the ends and next to a gap."""
    d = np.full_like(x, np.nan)
    if x.size < 3:
        return d
    span = t[2:] - t[:-2]
    with np.errstate(divide="ignore", invalid="ignore"):
        d[1:-1] = np.where(span > 0, (x[2:] - x[:-2]) / np.where(span > 0, span, 1.0), np.nan)
    gap = GAP_POLICY.splits(np.diff(t))
    d[np.r_[gap, False] | np.r_[False, gap]] = np.nan
    return d


def _slow_rate(x: np.ndarray, t: np.ndarray, half: float = ACCEL_HALF) -> np.ndarray:
    """dx/dt as (x(t + half) − x(t − half))/(2·half), x linearly interpolated between
    rows: the mean rate over 2·half s; NaN where that span leaves the log or crosses a gap."""
    lo, hi = np.interp(t - half, t, x), np.interp(t + half, t, x)
    seg = GAP_POLICY.pieces(t)
    i0 = np.clip(np.searchsorted(t, t - half), 0, t.size - 1)
    i1 = np.clip(np.searchsorted(t, t + half) - 1, 0, t.size - 1)
    ok = (t - half >= t[0]) & (t + half <= t[-1]) & (seg[i0] == seg) & (seg[i1] == seg)
    return np.where(ok, (hi - lo) / (2 * half), np.nan)


def _simpson_weights(t: np.ndarray) -> np.ndarray:
    """(n, 3) weights of rows k−1, k, k+1 whose sum is the mean over [t₋₁, t₊₁] of the
    parabola through the three (Simpson's rule on uneven steps h₀, h₁); the ends and
    repeated stamps get (0, 1, 0)."""
    w = np.zeros((t.size, 3))
    w[:, 1] = 1.0
    if t.size < 3:
        return w
    h0, h1 = np.diff(t)[:-1], np.diff(t)[1:]
    ok = (h0 > 0) & (h1 > 0)
    h0, h1 = np.where(ok, h0, 1.0), np.where(ok, h1, 1.0)
    inner = np.column_stack([(2 - h1 / h0) / 6, (h0 + h1) ** 2 / (6 * h0 * h1), (2 - h0 / h1) / 6])
    w[1:-1] = np.where(ok[:, None], inner, w[1:-1])
    return w


def _three(x: np.ndarray) -> np.ndarray:
    """(n, 3): x at the previous, this and the next row (the ends repeated)."""
    return np.column_stack([np.r_[x[:1], x[:-1]], x, np.r_[x[1:], x[-1:]]])


def _leaky_integral(x: np.ndarray, t: np.ndarray, tau: float = INTEGRAL_TAU) -> np.ndarray:
    """z' = x − z/τ along the log (reset across a gap), rad·s."""
    from scipy.signal import lfilter

    out = np.empty_like(x)
    for idx in label_rows(GAP_POLICY.pieces(t)):
        h = float(np.median(np.diff(t[idx]))) if idx.size > 1 else 0.2
        out[idx] = lfilter([h], [1.0, -math.exp(-h / tau)], np.nan_to_num(x[idx]))
    return out


def law_rows(log: Ride, k_t: float | None = None) -> LawRows:
    """The riding rows of ``log`` (speed above :data:`V_MIN`) with pitch, its rate, speed,
    acceleration and torque (phase current × ``k_t`` N·m/A, or in A without it).
    :class:`LawUnavailable` without pitch or torque, or with too few riding rows.
    """
    d = log.data
    d = d.loc[~spin_rows(d)].reset_index(drop=True)       # the wheel off the ground: no law
    if not log.has("tilt"):
        raise LawUnavailable("no pitch in this log (no tilt column, or all zero): the wheel's "
                             "balance law cannot be read")
    if log.has("torque"):
        channel, scale, unit = "torque", 1.0, "N·m"
    elif log.has("phase_current"):
        channel = "phase_current"
        scale, unit = (float(k_t), "N·m") if k_t else (1.0, "A")
    else:
        raise LawUnavailable("pitch is logged but neither phase current nor motor torque: "
                             "the torque the law commands is not in the log")
    t = d["t"].to_numpy(float)
    tilt = d["tilt"].to_numpy(float)
    v = d["v"].to_numpy(float)
    y = d[channel].to_numpy(float) * scale
    riding = (np.abs(v) > V_MIN) & np.isfinite(tilt) & np.isfinite(y)
    if riding.sum() < MIN_ROWS:
        raise LawUnavailable(f"{int(riding.sum())} riding rows with pitch and {channel} "
                             f"(speed above {V_MIN:g} m/s); at least {MIN_ROWS} are needed")
    level = float(np.median(tilt[riding]))
    riding &= np.abs(tilt - level) < MAX_PITCH
    finite = np.isfinite(tilt)
    tilt_f = np.interp(t, t[finite], tilt[finite])
    rate, acc = _rate(tilt_f, t), _slow_rate(v, t)
    z = _leaky_integral(np.where(riding, tilt_f - level, 0.0), t)
    ok = riding & np.isfinite(rate) & np.isfinite(acc)
    steps = np.diff(np.unique(np.round(tilt[finite], 9)))
    step = float(steps.min()) if steps.size else 0.0
    y_f = np.where(np.isfinite(y), y, 0.0)
    return LawRows(t=t[ok], tilt=tilt[ok], tilt_dot=rate[ok], v=np.abs(v[ok]), a=acc[ok] * np.sign(v[ok]),
                   z=z[ok], y=y[ok], channel=channel, unit=unit, scale=scale, pitch_step=step,
                   dt_median=float(np.median(np.diff(t))), w3=_simpson_weights(t)[ok],
                   tilt3=_three(tilt_f)[ok], v3=np.abs(_three(v))[ok], z3=_three(z)[ok],
                   y3=_three(y_f)[ok])
