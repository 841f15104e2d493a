"""The logged wheel speed as a simulator input (every gap bridged)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd

from euc_sim.errors import InputError
from euc_sim.rides.grids.power import G
from euc_sim.rides.grids.signals import battery_power_of, resample, sg
from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.rides.source.ride import Ride

__all__ = ["speed_profile", "rider_plan", "PLAN_WINDOW", "unpaid_spikes",
           "SPIN_POWER_FACTOR", "SPIN_POWER_MARGIN", "SPIN_GRADE", "SPIN_MIN_DT",
           "SPIN_MAX_SPAN", "SPIN_BACK"]

#: The rider's plan: the logged speed smoothed over this many s (it holds the rider's own
#: sway).  Value: docs/rider_calibration.md#proof-on-a-concealed-rider.
PLAN_WINDOW = 6.0

#: A wheel-speed rise is paid for while ½m(v₁² − v₀²) ≤ SPIN_POWER_FACTOR × the battery energy
#: + (SPIN_POWER_MARGIN W + m g SPIN_GRADE v̄) × the span (:func:`unpaid_spikes`; the steepest
#: descent allowed 15 %).  Values: docs/ride_falls.md#the-measured-cause.
SPIN_POWER_FACTOR = 2.0
SPIN_POWER_MARGIN = 500.0
SPIN_GRADE = 0.15
#: The rise is measured over at least this span, s: a log's near-repeated time stamps (0.02 s
#: apart on master_pro_V2/6) would turn a 0.1 m/s step into 5 m/s².
SPIN_MIN_DT = 0.3
UNKNOWN_POWER = 1e6       # W: a row without battery power pays for any rise
#: A free spin is followed at most SPIN_MAX_SPAN s after its top, ending where the speed is back
#: within SPIN_BACK m/s of where it rose from.  Values: docs/ride_falls.md.
SPIN_MAX_SPAN = 5.0
SPIN_BACK = 0.5


def speed_profile(log: Ride, rate: float = GAP_POLICY.rate, window: float = 1.5, polyorder: int = 2,
                  total_mass: float | None = None) -> pd.DataFrame:
    """The logged wheel speed as a simulator input: ``DataFrame(t, v)`` (s, m/s).

    A uniform grid at ``rate`` Hz from t = 0, smoothed by the Savitzky–Golay fit of
    :func:`~euc_sim.rides.grids.signals.ride_signals` (``window`` s, ``polyorder``).  Every
    gap is bridged linearly (a simulation needs a continuous profile); with ``total_mass``
    (kg) the spikes of :func:`unpaid_spikes` are bridged too.  ``attrs["notes"]`` says both.
    """
    t = log.data["t"].to_numpy()
    gaps = np.flatnonzero(np.diff(t) > GAP_POLICY.gap)
    notes = [f"gap of {t[i + 1] - t[i]:.2f} s at t = {t[i]:.2f} s bridged linearly" for i in gaps]
    if total_mass is not None:
        spikes = unpaid_spikes(log, total_mass)
        if spikes:
            drop = np.zeros(len(t), bool)
            for a, b in spikes:
                drop[a + 1:b] = True
            v_log = log.data["v"].to_numpy()
            rise = max(float(np.max(np.abs(v_log[a:b + 1])) - abs(v_log[a])) for a, b in spikes)
            notes.append(f"{len(spikes)} wheel-speed spike(s) the battery power cannot pay for "
                         f"(kinetic energy above {SPIN_POWER_FACTOR:g}× the battery energy + "
                         f"{SPIN_POWER_MARGIN:g} W + a {100 * SPIN_GRADE:g} % descent, m = "
                         f"{total_mass:.0f} kg: the wheel off the ground or slipping, not the rider "
                         f"speeding up) bridged linearly, {sum(t[b] - t[a] for a, b in spikes):.1f} s "
                         f"in all, rising up to {rise:.2f} m/s; at t = "
                         + ", ".join(f"{t[a]:.1f}" for a, _ in spikes[:10])
                         + (" s, ..." if len(spikes) > 10 else " s"))
            log = replace(log, data=log.data.loc[~drop].reset_index(drop=True))
    raw, _ = resample(log, rate, max_gap=GAP_POLICY.profile)
    v = sg(raw["v"].to_numpy(), np.zeros(len(raw), int), rate, window, polyorder)
    out = pd.DataFrame({"t": raw["t"].to_numpy(), "v": v})
    out.attrs["notes"] = notes
    out.attrs["source"] = log.path
    return out


def unpaid_spikes(log: Ride, total_mass: float) -> list[tuple[int, int]]:
    """Wheel-speed spikes the battery cannot pay for: the wheel, not the rider, sped up.

    A rise of |v| from row k to the first row j at least :data:`SPIN_MIN_DT` s later is
    unpaid when

        ½ m (v_j² − v_k²) > f·∫ max(P, 0) dt + (P_m + m g s v̄)(t_j − t_k)

    (m = ``total_mass`` kg, P battery power W, v̄ the mean of v_k and v_j; f, P_m, s:
    :data:`SPIN_POWER_FACTOR`, :data:`SPIN_POWER_MARGIN`, :data:`SPIN_GRADE`).  A spike runs
    from the first unpaid row through the top of the rise to where the speed is back within
    :data:`SPIN_BACK` of its start, at most :data:`SPIN_MAX_SPAN` s after the top.  Only rises are
    tested (a motor can brake at no battery power).  Returns (a, b) row indices of
    ``log.data`` around each spike (the rows strictly between are the spike); empty without
    battery power.
    """
    if not (math.isfinite(total_mass) and total_mass > 0):
        raise InputError(f"total_mass must be a positive number of kg, got {total_mass!r}")
    d = log.data
    P = battery_power_of(d)[0]
    if P is None or len(d) < 3:
        return []
    t, v = d["t"].to_numpy(float), np.abs(d["v"].to_numpy(float))
    P = np.maximum(np.nan_to_num(P, nan=UNKNOWN_POWER), 0.0)   # an unknown power pays for anything
    n = len(t)
    E = np.r_[0.0, np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(t))]     # J from the first row
    j = np.minimum(np.searchsorted(t, t + SPIN_MIN_DT), n - 1)          # first row ≥ SPIN_MIN_DT later
    span = t[j] - t
    gain = 0.5 * total_mass * (v[j] ** 2 - v ** 2)
    paid = SPIN_POWER_FACTOR * (E[j] - E) + (SPIN_POWER_MARGIN + total_mass * G * SPIN_GRADE * 0.5 * (v + v[j])) * span
    unpaid = (span > 0) & (gain > paid)
    out, k = [], 0
    while k < n - 1:
        if not unpaid[k]:
            k += 1
            continue
        start, last = k, int(j[k])             # the rise runs at least to j of every unpaid row
        while k + 1 <= last and k + 1 < n - 1:
            k += 1
            if unpaid[k]:
                last = max(last, int(j[k]))
        top = start + int(np.argmax(v[start:last + 1]))              # the top of the rise
        back = v[start] + SPIN_BACK
        after = np.arange(top + 1, n)
        after = after[t[after] - t[top] <= SPIN_MAX_SPAN]
        home = after[v[after] <= back]
        # the spike ends where the speed is back near where it rose from; a wheel that does
        # not come back within SPIN_MAX_SPAN ends at its slowest row in that time
        end = int(home[0]) if home.size else (int(after[np.argmin(v[after])]) if after.size else top)
        end = max(end, last)
        out.append((start, end))
        k = end
    return out


def rider_plan(t: np.ndarray, v: np.ndarray, window: float = PLAN_WINDOW) -> np.ndarray:
    """The speed the rider means to ride, m/s: ``v`` on the uniform grid ``t`` smoothed by a
    quadratic Savitzky–Golay fit over ``window`` s.
    """
    t = np.asarray(t, float)
    rate = 1.0 / float(np.median(np.diff(t)))
    return sg(np.asarray(v, float), np.zeros(t.size, int), rate, window, 2)
