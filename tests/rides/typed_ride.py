"""Typed ride results for the renderers' tests: a ride's numbers read from a log, a mass fit,
a battery verdict and a whole :class:`~euc_sim.rides.result.RideResult` with parts replaced."""

from __future__ import annotations

import warnings
from dataclasses import replace

from euc_sim.rides.drive.battery import BatteryHealth
from euc_sim.rides.drive.mass import MassFit
from euc_sim.rides.grids.power import SpeedScale
from euc_sim.rides.result import RiderNumbers
from euc_sim.rides.source.logs import read_log
from euc_sim.rides.summary.rider_view import rider_numbers


def read(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_log(path, emit_warnings=False)


def rider_of(path, **summary) -> RiderNumbers:
    """The summary, mass check, battery and clock of the log at ``path`` (no mass, no drivetrain),
    the summary's fields in ``summary`` replaced."""
    r = rider_numbers(read(path), None, {})
    return replace(r, summary=replace(r.summary, **summary)) if summary else r


def mass_fit(estimate=None, ci95=None, why: str = "", **kw) -> MassFit:
    """A total mass as reported, kg (not identified, with ``why``, by default)."""
    out = dict(coef={}, coef_ci95={}, terms=[], history=[], lag=0.0, scale=SpeedScale(1.0, 0.0, "assumed"),
               signed=True, n_samples=0, unidentified={})
    return MassFit(estimate=estimate, ci95=ci95, why=why, **{**out, **kw})


def battery(resistance_ohm=None, verdict: str = "cannot tell", **kw) -> BatteryHealth:
    """A battery verdict: the pack's resistance, Ω, and what it is judged against."""
    out = dict(resistance_ci95=None, temperature_C=None, resistance_25C_ohm=None, resistance_25C_ci95=None,
               per_cell_ohm=None, expected_ohm=None, expected_source=None, app_setting_ohm=None, sentence="")
    return BatteryHealth(resistance_ohm=resistance_ohm, verdict=verdict, **{**out, **kw})


def ride_entry_of(path: str, start: str, utc_offset_s=None, summary_fields=None, health=None, **kw):
    """A :class:`~euc_sim.rides.logbook.history.RideEntry` of the log ``path`` started at ``start``
    (ISO): its summary's ``summary_fields`` (:func:`summary`), its ``health`` (:func:`battery`, no
    resistance by default), no model, no temperature."""
    from euc_sim.rides.logbook.history import RideEntry

    out = dict(layout="eucworld" if utc_offset_s is not None else "wheellog", model=None, series=(),
               temperature_C=None, temperature_source=None)
    return RideEntry(path=path, start=start, utc_offset_s=utc_offset_s, summary=summary(**(summary_fields or {})),
                     battery=health or battery(), **{**out, **kw})


def history_of(rides, basis: str = "as measured", **kw):
    """A :class:`~euc_sim.rides.logbook.history.RideHistory` of the entries ``rides`` (no change
    test, no Wh/km slope, no trend unless given in ``kw``; the zone :func:`shared_offset`'s)."""
    from euc_sim.rides.logbook.history import RideHistory, shared_offset

    rides = tuple(rides)
    return RideHistory(rides=rides, basis=basis, **{"change": None, "whkm_slope": None, "whkm_slope_ci95": None,
                                                    "zone": shared_offset(e.utc_offset_s for e in rides), **kw})


def with_summary(res, **summary):
    """``res`` (a RideResult) with its summary's fields replaced."""
    return replace(res, rider=replace(res.rider, summary=replace(res.rider.summary, **summary)))


def summary(**fields):
    """A :class:`~euc_sim.rides.summary.summary.RideSummary` with ``fields`` given and every other
    required one unknown (no gaps, no limit known)."""
    from dataclasses import MISSING, fields as all_fields

    from euc_sim.rides.drive.cutout import Limits
    from euc_sim.rides.summary.summary import RideSummary

    unknown = {f.name: None for f in all_fields(RideSummary) if f.default is MISSING and f.default_factory is MISSING}
    return RideSummary(**{**unknown, "gaps": {}, "limits": Limits(None, None, None), **fields})
