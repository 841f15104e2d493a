"""The rider's numbers of one ride, for the ride JSON and page: summary, mass check, battery.

One entry point, :func:`rider_numbers`, called once by ``euc-sim ride``; each part
is a typed result of its own module (:mod:`euc_sim.rides.summary.summary`,
:mod:`euc_sim.rides.drive.battery`).
"""

from __future__ import annotations

import math
from pathlib import Path

from euc_sim.errors import InputError
from euc_sim.rides.source.ride import Ride

__all__ = ["rider_numbers", "compared_numbers", "check_rider_weight", "ride_clock", "zone_words"]


#: A rider's declared weight with gear, kg (``--rider-weight``).
RIDER_WEIGHT = (20.0, 250.0)


def check_rider_weight(kg: float | None) -> float | None:
    """The declared rider weight, kg, or a one-line ``ValueError`` naming ``--rider-weight``."""
    if kg is None:
        return None
    if not (math.isfinite(kg) and RIDER_WEIGHT[0] <= kg <= RIDER_WEIGHT[1]):
        raise InputError(f"--rider-weight is the rider's weight with gear, kg, between 20 and 250; got {kg!r}")
    return float(kg)


def zone_words(offset_s: float | None) -> str:
    """The zone of a clock, s east of UTC, in words: ``"UTC+02:00"``, or the phone's local time
    where the log names none (None)."""
    if offset_s is None:
        return "the phone's local time"
    m = int(round(abs(offset_s) / 60.0))
    return f"UTC{'-' if offset_s < 0 else '+'}{m // 60:02d}:{m % 60:02d}"


def ride_clock(log: Ride) -> dict:
    """When the ride ran, in its own zone: the ride JSON's ``clock``.

    Returns
    -------
    dict
        ``start`` (ISO 8601 clock time of the log's first row in the ride's own zone, with the
        offset where the log gives one), ``utc_offset_s`` (s east of UTC, None where the log
        names no zone: WheelLog writes the phone's local clock), ``zone`` (in words) and
        ``pauses`` ([[t0, t1], ...] s from the log's start: the intervals the summary leaves
        out of the duration).
    """
    from datetime import timedelta, timezone

    import numpy as np
    import pandas as pd

    from euc_sim.rides.source.gaps import GAP_POLICY

    off = log.utc_offset_s
    start = pd.Timestamp(log.start)
    if off is not None:
        start = (start + pd.Timedelta(seconds=off)).tz_localize(timezone(timedelta(seconds=off)))
    t = log.data["t"].to_numpy(float)
    i = np.flatnonzero(np.diff(t) > GAP_POLICY.pause)
    return {"start": start.isoformat(), "utc_offset_s": off, "zone": zone_words(off),
            "pauses": [[float(t[k]), float(t[k + 1])] for k in i]}


def rider_numbers(log: Ride, rep: dict, spec=None, rider_weight: float | None = None) -> dict:
    """``summary``, ``mass_check`` and ``battery`` of the ride JSON.

    Parameters
    ----------
    log : Ride
        The ride.
    rep : dict
        The ride JSON built so far: its ``total_mass`` and ``drivetrain`` are read,
        never recomputed.
    spec : WheelSpec, optional
        The wheel's weight (for the mass check) and pack (for the battery's verdict).
    rider_weight : float, optional
        The rider's declared weight, kg.

    Returns
    -------
    dict
        ``{"summary": ..., "mass_check": ..., "battery": ...}`` (JSON-ready).
    """
    from euc_sim.rides.drive.battery import battery_health_from_report, pack_spec
    from euc_sim.rides.summary.summary import mass_check, ride_summary

    summary = ride_summary(log, getattr(spec, "top_speed", None))
    wheel_kg = getattr(spec, "wheel_mass", None) if spec is not None else None
    mc = mass_check(rep.get("total_mass"), rider_weight, wheel_kg)
    bh = battery_health_from_report(rep.get("drivetrain"), log, log.counters, pack_spec(spec)).to_json()
    out = summary.to_json()
    # CONTRACT's summary.battery: the verdict and what it is judged against (the whole entry: battery)
    out["battery"] = {k: bh[k] for k in ("verdict", "expected_ohm", "expected_source")}
    return {"summary": out, "mass_check": mc.to_json(), "battery": bh, "clock": ride_clock(log)}


def compared_numbers(log, fitted, spec=None, rider_weight: float | None = None) -> dict:
    """The compared ride's own numbers: the ride JSON's ``compared``.

    Parameters
    ----------
    log : Ride
        The compared ride, parsed.
    fitted : RideDrivetrain
        Its mass and drivetrain analysis (the pipeline's ``test``), read, not redone.
    spec : WheelSpec, optional
    rider_weight : float, optional
        The declared weight of the compared ride's rider, kg.

    Returns
    -------
    dict
        ``recording``, ``total_mass``, ``unidentified``, and :func:`rider_numbers`'s
        ``summary``, ``mass_check``, ``battery`` and ``clock``, as LOG's are in the ride JSON.
    """
    from euc_sim.rides.drive.drivetrain_report import drivetrain_report

    view = drivetrain_report(log, fitted.spec, fitted=fitted)[0]
    return {"recording": Path(log.path).name, "total_mass": view["total_mass"], "unidentified": view["unidentified"],
            **rider_numbers(log, view, spec, rider_weight)}
