"""The ride as a rider reads it: distance, time, speed, energy, battery, PWM, alarms, gaps.

:func:`ride_summary` is a pure function of a parsed log and its counters; its
:class:`RideSummary` is the ride JSON's ``summary`` (docs/summary.md).  Energy is V·I
integrated (trapezoid, not across intervals over the gap policy's ``bridge``), drawn the
positive part and regenerated the negative; battery used is the start minus end
percentage at the lowest currents of :data:`BATTERY_WINDOW_S`.  What the log cannot give
is ``None``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from euc_sim.rides.drive.cutout import Limits, ride_limits
from euc_sim.rides.grids.spin import FreeSpins, free_spin, spin_stats
from euc_sim.rides.summary.distance import (_distance, _duration, _gap_distance, _near, _steps,
                                          _wheel_distance)
from euc_sim.rides.source.counters import counter_steps as _counter_steps, integrate_split as _integrate_split
from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.rides.source.ride import Ride

__all__ = ["RideSummary", "Gaps", "MassCheck", "ride_summary", "mass_check", "MOVING_MPS"]

#: Intervals up to this are integrated across (energy, distance); longer ones are not, s.
BRIDGE_S = GAP_POLICY.bridge
#: A gap longer than this, s, is a pause of the log (left out of the duration).
PAUSE_S = GAP_POLICY.pause
#: Wheel speed above which the wheel counts as moving, m/s (1.8 km/h).
MOVING_MPS = 0.5
#: Wheel speed above which the trip has started (the wheel's first turn), m/s (0.18 km/h).
START_MPS = 0.05
#: The span at each end of the ride over which the battery reading is taken, s.
BATTERY_WINDOW_S = 60.0
#: Less battery used than this, points, gives no range (the ratio would be noise).
MIN_BATTERY_FOR_RANGE = 3.0


@dataclass(frozen=True)
class Gaps:
    """The log's intervals longer than ``limit_s``: how many, their total and the longest, s."""

    count: int
    total_s: float
    longest_s: float
    limit_s: float


@dataclass(frozen=True)
class RideSummary:
    """The CONTRACT's ``summary`` object (SI units; ``None`` where the log cannot give it).

    Attributes are the JSON fields; see docs/summary.md for each one's definition.
    """

    duration_s: float
    moving_s: float
    distance_m: float | None
    distance_source: str | None
    speed_max_mps: float
    speed_mean_moving_mps: float | None
    energy_drawn_Wh: float | None
    energy_regen_Wh: float | None
    Wh_per_km: float | None
    battery_used_pct: float | None
    range_m_at_this_rate: float | None
    pwm_max_pct: float | None
    pwm_max_at_s: float | None
    alarms: int | None
    gaps: Gaps
    logged_s: float = 0.0
    distance_wheel_m: float | None = None
    distance_gps_m: float | None = None
    distance_speed_integral_m: float | None = None
    battery_start_pct: float | None = None
    battery_end_pct: float | None = None
    range_left_m: float | None = None
    safety_margin_min_pct: float | None = None
    pwm_max_place: dict | None = None
    free_spin: FreeSpins | None = None
    alarm_rows: int | None = None
    sampling_hz: float | None = None
    temperature_max_C: float | None = None
    quality: str = "good"
    quality_sentence: str = ""
    why: dict = field(default_factory=dict)
    limits: Limits | None = None
    distance_follows: str = ""
    duration_follows: str = ""


def _gaps(t: np.ndarray, limit: float) -> Gaps:
    """The intervals of ``t`` longer than ``limit``, s."""
    dt = np.diff(t)
    g = dt[dt > limit]
    return Gaps(int(g.size), float(g.sum()), float(g.max()) if g.size else 0.0, float(limit))


def _battery(d: pd.DataFrame, t0: float, t_move: float, t1: float) -> tuple[float | None, float | None]:
    """Battery %, from the log's start ``t0`` to :data:`BATTERY_WINDOW_S` after the first turn
    of the wheel ``t_move``, and over the last window before ``t1``; each the median at the
    lowest currents of its window (zero readings of a disconnecting wheel left out)."""
    if "battery" not in d:
        return None, None
    t, b = d["t"].to_numpy(float), d["battery"].to_numpy(float)
    cur = np.abs(d["current"].to_numpy(float)) if "current" in d else np.zeros_like(b)
    out = []
    for lo, hi in ((t0, t_move + BATTERY_WINDOW_S), (t1 - BATTERY_WINDOW_S, t1)):
        m = (t >= lo) & (t <= hi) & np.isfinite(b) & np.isfinite(cur) & (b > 0)
        if not m.any():
            out.append(None)
            continue
        calm = cur[m] <= np.quantile(cur[m], 0.10) + 1.0       # A: the calmest readings
        out.append(float(np.median(b[m][calm])))
    return out[0], out[1]


def _pwm(d: pd.DataFrame, skip: np.ndarray) -> tuple[float | None, float | None, dict | None]:
    """The largest logged duty, %, when, s, and where (nearest GPS fix within 10 s); rows
    ``skip`` (a free spin) left out."""
    if "pwm" not in d:
        return None, None, None
    p = np.where(skip, np.nan, d["pwm"].to_numpy(float))
    if not np.isfinite(p).any():
        return None, None, None
    i = int(np.nanargmax(p))
    t = d["t"].to_numpy(float)
    place = None
    if "latitude" in d and "longitude" in d:
        lat, lon = d["latitude"].to_numpy(float), d["longitude"].to_numpy(float)
        ok = np.flatnonzero(np.isfinite(lat) & np.isfinite(lon) & (np.abs(t - t[i]) <= 10.0))
        if ok.size:
            j = ok[np.argmin(np.abs(t[ok] - t[i]))]
            place = {"lat": float(lat[j]), "lon": float(lon[j])}
    return float(p[i]), float(t[i]), place


def _quality(t: np.ndarray, lim: float) -> tuple[str, str, float | None]:
    """``"good"``, ``"fair"`` or ``"poor"``, a sentence on the sampling and gaps, and the samples
    per second, over the log without its pauses (intervals over :data:`PAUSE_S`).  A gap is an
    interval over ``lim``; poor: over 20 % of the ride in gaps or under 1 sample/s; fair:
    over 5 % or under 2 samples/s.
    """
    dt = np.diff(t)
    pause = dt[dt > PAUSE_S]
    span = float(t[-1] - t[0] - pause.sum()) if t.size > 1 else 0.0
    hz = float(dt.size - pause.size) / span if span > 0 else None      # a median hides bursts between gaps
    gaps = _gaps(np.cumsum(np.r_[0.0, np.where(dt > PAUSE_S, 0.0, dt)]), lim)
    share = gaps.total_s / span if span > 0 else 0.0
    rate = f"{hz:.1f} samples/s" if hz else "unknown sampling rate"
    if gaps.count:
        g = (f"{gaps.count} gap(s) longer than {lim:g} s, {gaps.total_s:.0f} s in all "
             f"({100 * share:.0f} % of the log, longest {gaps.longest_s:.1f} s)")
    else:
        g = f"no gap longer than {lim:g} s"
    if pause.size:
        g += (f"; {pause.size} pause(s) of the log over {PAUSE_S / 60:.0f} min ({pause.sum() / 60:.0f} min) "
              f"left out")
    if share > 0.20 or (hz is not None and hz < 1.0):
        q = "poor"
    elif share > 0.05 or (hz is not None and hz < 2.0):
        q = "fair"
    else:
        q = "good"
    tail = {"good": "", "fair": "; the figures below are a little less certain",
            "poor": "; treat every verdict below as weak"}[q]
    return q, f"Data quality {q}: {rate}, {g}{tail}.", hz


def ride_summary(log: Ride, top_speed_mps: float | None = None) -> RideSummary:
    """The ride's summary from its parsed log; ``top_speed_mps`` (the spec's, m/s) is the
    ``limits``' speed limit where the log has none.
    """
    d = log.data
    t, v = d["t"].to_numpy(float), np.abs(d["v"].to_numpy(float))
    why: dict[str, str] = {}
    c = log.counters
    moving = v > MOVING_MPS
    duration, t_start, duration_follows = _duration(t, v > START_MPS, c.duration_s)
    dt, ok = _steps(t)
    moving_own = float(np.sum(dt[ok & (moving[1:] | moving[:-1])]))
    moving_s = moving_own
    if _near(c.moving_s, moving_own):                       # the app's riding clock
        moving_s = float(c.moving_s)
        duration_follows = duration_follows.replace("trip clock", "trip and riding clocks")
    steps = _counter_steps(d)
    wheel, covered, gps, gps_why, wheel_follows, gps_follows = _distance(d, steps, log.layout)
    dist, source, follows = (gps, "gps", gps_follows) if gps is not None else (wheel, "wheel", wheel_follows)
    # energy is integrated over the bridged intervals only: so is the distance it is divided by
    covered_dist = covered * (dist / wheel if wheel > 0 else 1.0)
    integral_m = _wheel_distance(t, v) + _gap_distance(d, steps[0])
    if gps_why:
        why["distance_gps_m"] = gps_why
    drawn = regen = None
    if "voltage" in d and "current" in d:
        drawn, regen = _integrate_split(t, d["voltage"].to_numpy(float) * d["current"].to_numpy(float))
        if regen is not None and not (d["current"] < -0.5).mean() > 0.005:
            regen, why["energy_regen_Wh"] = None, "the logged current is never negative (not signed)"
    else:
        why["energy_drawn_Wh"] = "no battery voltage and current in the log"
    net = None if drawn is None else drawn - (regen or 0.0)
    whkm = net / (covered_dist / 1000.0) if net is not None and covered_dist > 100.0 else None
    b0, b1 = _battery(d, float(t[0]), max(t_start, float(t[0])), float(t[-1]))
    used = b0 - b1 if b0 is not None and b1 is not None else None
    rng = left = None
    if used is not None and used >= MIN_BATTERY_FOR_RANGE:
        rng, left = dist * 100.0 / used, dist * b1 / used
    elif used is not None:
        why["range_m_at_this_rate"] = f"only {used:.1f} % of the battery used"
    spin = free_spin(t, v, BRIDGE_S)              # the wheel off the ground: not the ride's top speed or PWM
    if spin.any():
        why["speed_max_mps"] = "rows where the wheel spins off the ground (free_spin) left out"
    pmax, pat, place = _pwm(d, spin)
    lim = GAP_POLICY.gap_of(log.layout)
    gaps = _gaps(t, lim)
    q, sentence, hz = _quality(t, lim)
    temp = float(np.nanmax(d["temperature"])) if "temperature" in d else None
    return RideSummary(
        duration_s=duration, moving_s=moving_s, distance_m=dist,
        distance_source=source, speed_max_mps=float(np.nanmax(np.where(spin, np.nan, v))),
        speed_mean_moving_mps=covered_dist / moving_own if moving_own > 0 else None,
        energy_drawn_Wh=drawn, energy_regen_Wh=regen, Wh_per_km=whkm, battery_used_pct=used,
        range_m_at_this_rate=rng, pwm_max_pct=pmax, pwm_max_at_s=pat,
        alarms=c.alarm_episodes, gaps=gaps, logged_s=float(t[-1] - t[0]),
        distance_wheel_m=wheel, distance_gps_m=gps, distance_speed_integral_m=integral_m, battery_start_pct=b0, battery_end_pct=b1,
        range_left_m=left, safety_margin_min_pct=None if pmax is None else 100.0 - pmax,
        pwm_max_place=place, free_spin=spin_stats(t, v, spin), alarm_rows=c.alarm_rows, sampling_hz=hz, temperature_max_C=temp,
        quality=q, quality_sentence=sentence, why=why,
        limits=ride_limits(c.speed_limit_mps, top_speed_mps),
        distance_follows=follows, duration_follows=duration_follows)


@dataclass(frozen=True)
class MassCheck:
    """The log's total mass against the rider's declared weight plus the wheel's (kg).

    ``declared_rider_kg``, ``wheel_kg``, ``declared_total_kg``; ``log_total_kg`` with
    ``log_ci95``; ``difference_kg`` (log minus declared) with ``difference_ci95``;
    ``verdict`` (``"consistent"``, ``"heavier"``, ``"lighter"``, ``"cannot tell"``);
    ``sentence``.
    """

    declared_rider_kg: float | None
    wheel_kg: float | None
    declared_total_kg: float | None
    log_total_kg: float | None
    log_ci95: tuple | None
    difference_kg: float | None
    difference_ci95: tuple | None
    verdict: str
    sentence: str


def mass_check(total_mass, rider_kg: float | None, wheel_kg: float | None) -> MassCheck:
    """Test the declared weight (rider with gear + the spec's wheel, kg) against the log's
    total mass: ``consistent`` when it lies inside the 95 % interval; never the answer.
    """
    est = getattr(total_mass, "estimate", None)
    ci = getattr(total_mass, "ci95", None)
    declared = rider_kg + wheel_kg if rider_kg is not None and wheel_kg is not None else None
    base = dict(declared_rider_kg=rider_kg, wheel_kg=wheel_kg, declared_total_kg=declared,
                log_total_kg=est, log_ci95=tuple(ci) if ci else None)
    if rider_kg is None:
        why = "No rider weight declared (--rider-weight KG)."
    elif wheel_kg is None:
        why = ("The wheel's weight is unknown (--wheel SPEC.csv or --wheel-mass): "
               "the declared weight cannot be checked.")
    elif est is None or not ci:
        why = (f"The log does not give the total mass ({total_mass.why if est is None else 'not identified'}); "
               f"the declared {rider_kg:.0f} kg is not checked.")
    else:
        why = None
    if why:
        return MassCheck(**base, difference_kg=None, difference_ci95=None, verdict="cannot tell", sentence=why)
    diff, dci = est - declared, (ci[0] - declared, ci[1] - declared)
    if dci[0] <= 0 <= dci[1]:
        verdict = "consistent"
        s = (f"Consistent: the log's {est:.0f} kg [{ci[0]:.0f}, {ci[1]:.0f}] includes the declared "
             f"{rider_kg:.0f} kg rider + {wheel_kg:.1f} kg wheel.")
    else:
        verdict = "heavier" if diff > 0 else "lighter"
        s = (f"The log says {abs(diff):.0f} kg {'more' if diff > 0 else 'less'} than declared "
             f"({rider_kg:.0f} kg rider + {wheel_kg:.1f} kg wheel), 95 % [{dci[0]:+.0f}, {dci[1]:+.0f}] kg.")
    return MassCheck(**base, difference_kg=diff, difference_ci95=dci, verdict=verdict, sentence=s)
