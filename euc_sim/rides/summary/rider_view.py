"""The rider's numbers of one ride, for the ride JSON and page: summary, mass check, battery.

One entry point, :func:`rider_numbers`, called once by ``euc-sim ride``; each part
is a typed result of its own module (:mod:`euc_sim.rides.summary.summary`,
:mod:`euc_sim.rides.drive.battery`).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import timedelta, timezone

import numpy as np

from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.rides.source.ride import Ride

__all__ = ["Clock", "RiderNumbers", "rider_numbers", "ride_clock", "zone_words"]


def zone_words(offset_s: float | None) -> str:
    """The zone of a clock, s east of UTC, in words: ``"UTC+02:00"``, or the phone's local time
    where the log names none (None)."""
    if offset_s is None:
        return "the phone's local time"
    m = int(round(abs(offset_s) / 60.0))
    return f"UTC{'-' if offset_s < 0 else '+'}{m // 60:02d}:{m % 60:02d}"


@dataclass(frozen=True)
class Clock:
    """When a ride ran, in its own zone: ``start`` (ISO, with the offset where the log gives
    one), ``utc_offset_s`` (s east of UTC, or None), ``zone`` in words, and the ``pauses``
    (s from the start) left out of the duration.
    """

    start: str
    utc_offset_s: float | None
    zone: str
    pauses: tuple = ()


def ride_clock(log: Ride) -> Clock:
    """When the ride ran, in its own zone (the ride JSON's ``clock``)."""
    import pandas as pd

    off = log.utc_offset_s
    start = pd.Timestamp(log.start)
    if off is not None:
        start = (start + pd.Timedelta(seconds=off)).tz_localize(timezone(timedelta(seconds=off)))
    t = log.data["t"].to_numpy(float)
    i = np.flatnonzero(np.diff(t) > GAP_POLICY.pause)
    return Clock(start.isoformat(), off, zone_words(off), tuple((float(t[k]), float(t[k + 1])) for k in i))


@dataclass(frozen=True)
class RiderNumbers:
    """The numbers a rider reads first, of one ride.

    Attributes
    ----------
    summary : RideSummary
        Distance, time, speed, energy, battery, limits.
    mass_check : MassCheck
        The declared rider weight against the log's total mass.
    battery : BatteryHealth
        The pack's internal resistance against what its cells give.
    clock : Clock
        When the ride ran, in its zone.
    """

    summary: RideSummary
    mass_check: MassCheck
    battery: BatteryHealth
    clock: Clock


def rider_numbers(log: Ride, total_mass, drivetrain, spec=None, rider_weight: float | None = None) -> RiderNumbers:
    """The rider's numbers of one ride, from ``total_mass`` and the
    ``drivetrain`` terms as reported (never recomputed), the ``spec``'s wheel weight and pack,
    and the rider's declared weight (kg).
    """
    from euc_sim.rides.drive.battery import battery_health_of, pack_spec  # deferred: loads euc_sim.rides.drive.battery (0.003 s), not loaded by --help
    from euc_sim.rides.summary.summary import mass_check, ride_summary  # deferred: loads scipy (1.1 s)

    summary = ride_summary(log, getattr(spec, "top_speed", None))
    mc = mass_check(total_mass, rider_weight, getattr(spec, "wheel_mass", None))
    bh = battery_health_of((drivetrain or {}).get("internal_resistance"), log.counters, pack_spec(spec))
    return RiderNumbers(summary, mc, bh, ride_clock(log))
