"""The rider's numbers of one ride, for the ride JSON and page: summary, mass check, battery.

One entry point, :func:`rider_numbers`, called once by ``euc-sim ride``; each part
is a typed result of its own module (:mod:`euc_sim.rides.report.summary`,
:mod:`euc_sim.rides.drive.battery`).
"""

from __future__ import annotations

import math

from euc_sim.errors import InputError
from euc_sim.rides.source.ride import Ride

__all__ = ["rider_numbers", "check_rider_weight"]


#: A rider's declared weight with gear, kg (``--rider-weight``).
RIDER_WEIGHT = (20.0, 250.0)


def check_rider_weight(kg: float | None) -> float | None:
    """The declared rider weight, kg, or a one-line ``ValueError`` naming ``--rider-weight``."""
    if kg is None:
        return None
    if not (math.isfinite(kg) and RIDER_WEIGHT[0] <= kg <= RIDER_WEIGHT[1]):
        raise InputError(f"--rider-weight is the rider's weight with gear, kg, between 20 and 250; got {kg!r}")
    return float(kg)


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
    from euc_sim.rides.report.summary import mass_check, ride_summary

    summary = ride_summary(log, getattr(spec, "top_speed", None))
    wheel_kg = getattr(spec, "wheel_mass", None) if spec is not None else None
    mc = mass_check(rep.get("total_mass"), rider_weight, wheel_kg)
    bh = battery_health_from_report(rep.get("drivetrain"), log, log.counters, pack_spec(spec)).to_json()
    out = summary.to_json()
    # CONTRACT's summary.battery: the verdict and what it is judged against (the whole entry: battery)
    out["battery"] = {k: bh[k] for k in ("verdict", "expected_ohm", "expected_source")}
    return {"summary": out, "mass_check": mc.to_json(), "battery": bh}
