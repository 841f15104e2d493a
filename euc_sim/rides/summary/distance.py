"""The ride's distance and duration: the app's own counters where the log has them, else
GPS, the wheel's counters or the integrated speed; each says which it follows
(``distance_follows``, ``duration_follows``, docs/summary.md).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from euc_sim.geo import haversine
from euc_sim.rides.source.counters import rises as _rises
from euc_sim.rides.source.gaps import GAP_POLICY

#: Intervals up to this are integrated across (energy, distance); longer ones are not, s.
BRIDGE_S = GAP_POLICY.bridge
#: A gap longer than this, s, is a pause of the log (left out of the duration).
PAUSE_S = GAP_POLICY.pause
#: A GPS track is used for the distance when it covers this share of the moving time ...
GPS_COVERAGE = 0.8
#: ... and its distance over the covered intervals is within this ratio band of the wheel's.
GPS_RATIO = (0.8, 1.2)
#: The app's own GPS distance is used where its readings span this share of the wheel's
#: distance (less would miss more than the 2 % the distance is held to).
GPS_COUNTER_COVERAGE = 0.98
#: The wheel's own counter is used where it agrees with the speed integral within this share.
COUNTER_AGREE = 0.10
#: Intervals up to this are integrated across for the distance where the log has no counter, s
#: (:attr:`GapPolicy.distance`).
DISTANCE_BRIDGE_S = GAP_POLICY.distance
#: Layouts whose counters count the app's trip (from 0 at its start), not the log.
TRIP_LAYOUTS = ("eucworld",)
#: The app's trip clock is followed where it is within this ratio band of our own duration.
CLOCK_RATIO = (0.5, 1.5)


def _steps(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Interval lengths, s, and which of them are bridged (not longer than BRIDGE_S)."""
    dt = np.diff(t)
    return dt, dt <= BRIDGE_S


def _wheel_distance(t: np.ndarray, v: np.ndarray) -> float:
    """The wheel speed integrated over the bridged intervals, m."""
    dt, ok = _steps(t)
    seg = 0.5 * (np.abs(v[1:]) + np.abs(v[:-1])) * dt
    return float(seg[ok].sum())


def _gap_distance(d: pd.DataFrame, inc: np.ndarray | None) -> float:
    """Distance the log's counter adds (``inc``, :func:`~euc_sim.rides.source.counters.counter_steps`)
    over the intervals not bridged, m."""
    ok = _steps(d["t"].to_numpy(float))[1]
    if inc is None or ok.all():
        return 0.0
    return float(np.nansum(inc[~ok]))


def _gps_distance(d: pd.DataFrame, w: np.ndarray) -> tuple[float | None, str | None]:
    """The GPS track's length while moving, m, or None with why; hops longer than
    :attr:`GapPolicy.gps_hop` filled with the wheel's distance ``w`` scaled by the track/wheel ratio.
    """
    if "latitude" not in d or "longitude" not in d:
        return None, "no GPS position in the log"
    t = d["t"].to_numpy(float)
    lat, lon = d["latitude"].to_numpy(float), d["longitude"].to_numpy(float)
    fix = np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) + np.abs(lon) > 0)
    if fix.sum() < 10:
        return None, "fewer than 10 GPS fixes"
    idx = np.flatnonzero(fix)
    new = np.r_[True, (np.diff(lat[idx]) != 0) | (np.diff(lon[idx]) != 0)]
    idx = idx[new]
    if idx.size < 10:
        return None, "the GPS position hardly changes"
    hop = haversine(lat[idx][:-1], lon[idx][:-1], lat[idx][1:], lon[idx][1:])
    ti = t[idx]
    cum = np.r_[0.0, np.cumsum(w)]
    wheel_hop = np.diff(cum[idx])
    short = np.diff(ti) <= GAP_POLICY.gps_hop
    moving_cover = wheel_hop[short].sum() / max(cum[-1], 1e-9)
    if moving_cover < GPS_COVERAGE:
        return None, f"the GPS track covers {100 * moving_cover:.0f} % of the wheel's distance"
    # hops faster than 1.5x the wheel plus 5 m/s are fix jumps: counted at the wheel's length
    dt_h = np.maximum(np.diff(ti), 1e-3)
    jump = hop / dt_h > 1.5 * (wheel_hop / dt_h) + 5.0
    use = short & ~jump
    ratio = hop[use].sum() / max(wheel_hop[use].sum(), 1e-9)
    if not GPS_RATIO[0] <= ratio <= GPS_RATIO[1]:
        return None, f"the GPS track is {ratio:.2f}x the wheel's distance (not sane)"
    return float(hop[use].sum() + ratio * wheel_hop[~use].sum()), None


def _trip_start(x: np.ndarray, layout: str | None) -> float:
    """A trip counter's first reading where the app's counters count its trip (:data:`TRIP_LAYOUTS`):
    the trip before the log's first row; 0 where that reading is not small beside the
    counter's rise over the log (a log holding part of a longer trip)."""
    f = x[np.isfinite(x)]
    if layout not in TRIP_LAYOUTS or f.size < 2 or not 0 < f[0] <= 0.5 * (f.max() - f[0]):
        return 0.0
    return float(f[0])


def _gps_counter(d: pd.DataFrame, w: np.ndarray, layout: str | None) -> tuple[float | None, str | None]:
    """The app's own GPS distance over the log, m, or None with the reason it is not used.

    Used where its readings span :data:`GPS_COUNTER_COVERAGE` of the wheel's distance ``w``
    (per interval, m) and agree in scale with it (:data:`GPS_RATIO`).
    """
    if "gps_distance" not in d:
        return None, "no GPS distance counter in the log"
    t, g = d["t"].to_numpy(float), d["gps_distance"].to_numpy(float)
    inc = _rises(t, g, 2.0 * max(float(np.nanmax(np.abs(d["v"]))), 1.0))
    idx = np.flatnonzero(np.isfinite(g))
    if idx.size < 2:
        return None, "the app's GPS distance has fewer than 2 readings"
    span = np.zeros(w.size, bool)
    span[idx[0]:idx[-1]] = True              # a counter counts across its empty cells
    share = w[span].sum() / max(w.sum(), 1e-9)
    if share < GPS_COUNTER_COVERAGE:
        return None, f"the app's GPS distance covers {100 * share:.0f} % of the wheel's"
    ratio = np.nansum(inc) / max(w[span].sum(), 1e-9)
    if not GPS_RATIO[0] <= ratio <= GPS_RATIO[1]:
        return None, f"the app's GPS distance is {ratio:.2f}x the wheel's (not sane)"
    return _trip_start(g, layout) + float(np.nansum(inc)), None


def _distance(d: pd.DataFrame, steps: tuple, layout: str | None = None):
    """The wheel's distance, its part over the bridged intervals, the GPS distance (or None),
    why GPS is not used (or None), m; and what the two follow, in words; ``steps``: the log's
    :func:`~euc_sim.rides.source.counters.counter_steps`.

    The wheel's distance is its trip counter or odometer (with the trip before the first
    row, :func:`_trip_start`) where it agrees with the speed integral within
    :data:`COUNTER_AGREE`, else the speed integrated over intervals up to
    :data:`DISTANCE_BRIDGE_S`.  The GPS distance is the app's counter, else the track.
    """
    t, v = d["t"].to_numpy(float), np.abs(d["v"].to_numpy(float))
    dt, ok = _steps(t)
    trap = 0.5 * (v[1:] + v[:-1]) * dt
    inc, col = steps
    follows = f"the wheel's speed integrated, gaps up to {DISTANCE_BRIDGE_S:.0f} s bridged"
    start = 0.0
    if inc is not None:
        name = "trip counter" if col == "distance" else "odometer"
        # like with like, away from the gaps (a counter read late lags one by a row)
        both = ok & np.r_[True, ok[:-1]] & np.r_[ok[1:], True] & np.isfinite(inc)
        ratio = inc[both].sum() / max(trap[both].sum(), 1e-9)
        if abs(ratio - 1.0) <= COUNTER_AGREE:
            follows, start = f"the wheel's {name}", _trip_start(d[col].to_numpy(float), layout)
        else:
            follows += f" (its {name} reads {100 * (ratio - 1):+.0f} %)"
            inc = None
    w = np.where(dt <= DISTANCE_BRIDGE_S, trap, 0.0)
    if inc is not None:
        w = np.where(np.isfinite(inc), inc, w)
    wheel = start + float(w.sum())
    gps, why_counter = _gps_counter(d, w, layout)
    gps_follows, why = "the app's GPS distance", None
    if gps is None:
        gps, why = _gps_distance(d, w)
        gps_follows = "the GPS track" + (f" ({why_counter})" if "gps_distance" in d else "")
    return wheel, float(w[ok].sum()), gps, why, follows, gps_follows


def _near(clock: float | None, own: float) -> bool:
    """Whether an app's ``clock`` (s) is within :data:`CLOCK_RATIO` of our own figure ``own`` (s)."""
    return clock is not None and own > 0 and CLOCK_RATIO[0] <= clock / own <= CLOCK_RATIO[1]


def _duration(t: np.ndarray, rolling: np.ndarray, clock: float | None = None) -> tuple[float, float, str]:
    """The ride's duration, s; the time of the wheel's first turn, s; and what the duration
    follows, in words: the app's trip ``clock`` at the end (s) where the log has one within
    :data:`CLOCK_RATIO` of our own, else the time from the first turn of the wheel to the
    last sample, pauses (intervals over :data:`PAUSE_S`) left out."""
    t_start = float(t[np.flatnonzero(rolling)[0]]) if rolling.any() else float(t[0])
    dt = np.diff(t)
    paused = float(dt[(dt > PAUSE_S) & (t[1:] > t_start)].sum())
    own = float(t[-1] - t_start - paused)
    if _near(clock, own):
        return float(clock), t_start, "the app's trip clock"
    follows = "the wheel's first turn to the last row" + (", pauses left out" if paused else "")
    if clock is not None:
        follows += f" (the app's trip clock reads {clock:.0f} s)"
    return own, t_start, follows
