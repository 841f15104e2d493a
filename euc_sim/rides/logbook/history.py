"""Many rides of one wheel: the battery's resistance over time, consumption against speed.

:func:`ride_entry` reads one log (its summary and battery resistance, as ``euc-sim ride``
reports them); :func:`ride_history` joins one wheel's entries with a change test of the
latest ride's resistance against the earlier rides' prediction interval
(:func:`change_test`) and the slope of Wh/km against mean moving speed.  Resistances are
compared at 25 °C where every ride logs the battery temperature (``basis``).
"""

from __future__ import annotations

import math
import warnings
from collections import Counter
from dataclasses import dataclass, field
from datetime import datetime, timedelta

import numpy as np

from euc_sim.errors import InputError
from euc_sim.rides.drive.battery import BatteryHealth, battery_health, measure_resistance, trend_words
from euc_sim.rides.grids.signals import check_readings
from euc_sim.rides.source.logs import read_log
from euc_sim.rides.summary.summary import RideSummary, ride_summary

__all__ = ["RideEntry", "ChangeTest", "RideHistory", "WheelMismatch", "ride_entry",
           "change_test", "ride_history", "series_cells", "full_charge", "shared_offset", "utc_start",
           "SERIES_COUNTS"]

#: Cells in series of common EUC packs (67.2 V to 176.4 V full).
SERIES_COUNTS = (16, 20, 24, 30, 32, 36, 40, 42)


class WheelMismatch(InputError):
    """Logs that are not of one wheel; the message names the file."""


@dataclass(frozen=True)
class RideEntry:
    """One ride of the history.

    Attributes
    ----------
    path, layout : str
    start : str
        ISO wall-clock time of the first sample (UTC where the log names its zone).
    summary : RideSummary
    battery : BatteryHealth
    model : str or None
        The wheel's model and serial where the app wrote them.
    series : tuple of int
        Cell counts in series the ride's voltages allow (:func:`series_cells`).
    temperature_C, temperature_source : float, str or None
        Battery temperature where logged, else the median controller temperature.
    full_charge_V : float or None
        :func:`full_charge`, V.
    repairs : tuple of str
        What the reader changed in the log.
    utc_offset_s : float or None
        The log's zone, s east of UTC.
    """

    path: str
    start: str
    layout: str
    summary: RideSummary
    battery: BatteryHealth
    model: str | None
    series: tuple
    temperature_C: float | None
    temperature_source: str | None
    full_charge_V: float | None = None
    repairs: tuple = ()
    utc_offset_s: float | None = None


@dataclass(frozen=True)
class ChangeTest:
    """Latest ride against the earlier ones (Ω): ``latest`` ± ``latest_se``; the earlier rides'
    ``earlier_mean`` ± ``earlier_se`` and ``between_ride_sd``; ``difference`` from the
    prediction for a new ride with ``difference_ci95``; ``z``, ``p_value``; ``verdict``
    (``"changed"`` at p < 0.05, else ``"no change shown"``); ``n_earlier``; ``note``.
    """

    latest: float
    latest_se: float
    earlier_mean: float
    earlier_se: float
    between_ride_sd: float
    difference: float
    difference_ci95: tuple
    z: float
    p_value: float
    verdict: str
    n_earlier: int
    note: str = ""


@dataclass(frozen=True)
class RideHistory:
    """The ``euc-sim rides`` result (SI units).

    Attributes
    ----------
    rides : tuple of RideEntry
        In order of their start (:func:`utc_start`).
    basis : str
        ``"25C"`` or ``"as measured"``.
    change : ChangeTest or None
        None under two rides with a resistance (``why``).
    whkm_slope, whkm_slope_ci95 : float or None
        Wh/km per (m/s) of mean moving speed, least squares over the rides.
    why : dict
    trend : str or None
        :func:`~euc_sim.rides.drive.battery.trend_words` of the resistances.
    zone : float or None
        The zone the rides are sorted in (:func:`shared_offset`), s east of UTC.
    """

    rides: tuple
    basis: str
    change: ChangeTest | None
    whkm_slope: float | None
    whkm_slope_ci95: tuple | None
    why: dict = field(default_factory=dict)
    trend: str | None = None
    zone: float | None = None


def shared_offset(offsets) -> float | None:
    """The zone (s east of UTC) most of the logs naming one give, the first of equals; None
    where none does.  Logs naming none are taken to be in it.
    """
    offs = Counter(o for o in offsets if o is not None)
    return offs.most_common(1)[0][0] if offs else None


def utc_start(start: str, utc_offset_s: float | None, shared: float | None):
    """The instant a ride started, naive UTC: ``start`` where its log names its zone, else the
    phone's clock taken in the ``shared`` zone (as logged without one).
    """
    t = datetime.fromisoformat(start)
    return t if utc_offset_s is not None or shared is None else t - timedelta(seconds=shared)


def series_cells(v_max: float, v_min: float) -> tuple[int, ...]:
    """Cell counts in series consistent with the ride's voltages (3.0-4.25 V a cell)."""
    return tuple(n for n in SERIES_COUNTS if 3.0 * n <= v_min and v_max <= 4.25 * n)


#: Full-charge voltages (:func:`full_charge`) differing by more than this fraction: different
#: packs (one wheel's rides agree within 3 %; 30 and 32 cells are 6.7 % apart).
FULL_CHARGE_SPREAD = 0.05


def full_charge(log) -> float | None:
    """The full-charge voltage the log's voltage and battery % imply, V (None without both): the
    median over low-current rows of V·4.2/(3.3 + 0.9·b/100), the apps' % running about
    linearly from 3.3 V (0 %) to 4.2 V (100 %) a cell.
    """
    d = log.data
    if not {"voltage", "battery"} <= set(d.columns):
        return None
    V, b = d["voltage"].to_numpy(float), d["battery"].to_numpy(float)
    ok = np.isfinite(V) & np.isfinite(b) & (V > 0) & (b > 0)
    if "current" in d:
        ok &= np.abs(d["current"].to_numpy(float)) < 5.0
    if ok.sum() < 20:
        return None
    return float(np.median(V[ok] * 4.2 / (3.3 + 0.009 * b[ok])))


def ride_entry(path, pack=None, n_boot: int = 100, seed: int = 0) -> RideEntry:
    """Read one log: its summary and battery resistance; the reader's errors name the file."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        log = read_log(path, emit_warnings=False)
        check_readings(log)                 # the per-log checks of ``euc-sim ride`` too
        counters = log.counters
        summary = ride_summary(log)
        try:
            r, ci = measure_resistance(log, n_boot, seed)
            why = None
        except ValueError as exc:
            r, ci, why = None, None, str(exc)
    temp, tsrc = counters.battery_temp_C, "battery"
    if temp is None and "temperature" in log.data:
        temp, tsrc = float(np.nanmedian(log.data["temperature"])), "controller"
    elif temp is None:
        tsrc = None
    bh = battery_health(r, ci, counters.battery_temp_C, pack, counters.battery_circuit_ohm, why)
    volt = log.data["voltage"].to_numpy(float) if "voltage" in log.data else np.array([np.nan])
    vf = volt[np.isfinite(volt) & (volt > 0)]
    series = series_cells(float(vf.max()), float(np.quantile(vf, 0.01))) if vf.size else ()
    return RideEntry(path=str(path), start=log.start.isoformat(), layout=log.layout,
                     summary=summary, battery=bh, model=counters.wheel_model,
                     series=series, temperature_C=temp, temperature_source=tsrc,
                     full_charge_V=full_charge(log), repairs=tuple(log.repairs), utc_offset_s=log.utc_offset_s)


def check_one_wheel(entries) -> None:
    """Raise :class:`WheelMismatch` naming the first log whose wheel differs from the first's."""
    first = entries[0]
    allowed = set(first.series)
    for e in entries[1:]:
        if first.model and e.model and e.model != first.model:
            raise WheelMismatch(f"{e.path}: a different wheel ({e.model}) from {first.path} "
                                f"({first.model}); give the logs of one wheel")
        full = (first.full_charge_V, e.full_charge_V)
        if None not in full and abs(full[1] - full[0]) > FULL_CHARGE_SPREAD * full[0]:
            raise WheelMismatch(f"{e.path}: a different wheel from {first.path}: its voltage and battery % "
                                f"give a full charge of {full[1]:.0f} V against {full[0]:.0f} V (more than "
                                f"{FULL_CHARGE_SPREAD:.0%} apart); give the logs of one wheel")
        allowed &= set(e.series)
        if first.series and e.series and not allowed:
            raise WheelMismatch(f"{e.path}: its battery voltage ({'/'.join(map(str, e.series))} cells "
                                f"in series) does not fit {first.path}'s; give the logs of one wheel")


def change_test(values, cis) -> ChangeTest:
    """Is the last of ``values`` (Ω, time order, 95 % intervals ``cis``) different from the earlier ones?

    With k ≥ 2 earlier rides (mean x̄, variance s²): t = (R_last − x̄)/√(s²·(1 + 1/k) +
    max(0, se_last² − mean se²)), Student's t with k − 1 degrees of freedom, two-sided.  With
    one earlier ride, a z test on the rides' own errors (liberal, said in ``note``).
    """
    from scipy.stats import norm
    from scipy.stats import t as student

    x = np.asarray(values, float)
    se = np.array([max((c[1] - c[0]) / (2 * 1.959964), 1e-12) for c in cis])     # half-width / 1.96
    xe, se_e = x[:-1], se[:-1]
    k = xe.size
    mu = float(xe.mean())
    own = float(np.mean(se_e ** 2))
    if k >= 2:
        s2 = max(float(np.var(xe, ddof=1)), own)
        sd = math.sqrt(s2 * (1 + 1 / k) + max(0.0, se[-1] ** 2 - own))
        dist, note, se_mu, tau = student(k - 1), "", math.sqrt(s2 / k), math.sqrt(max(0.0, s2 - own))
    else:
        sd = math.sqrt(se[-1] ** 2 + own)
        dist, se_mu, tau = norm(), math.sqrt(own), 0.0
        note = "one earlier ride: the ride-to-ride spread is unknown and left out (the test is liberal)"
    diff = float(x[-1] - mu)
    stat = diff / sd
    p = float(2 * dist.sf(abs(stat)))
    h = float(dist.ppf(0.975)) * sd
    return ChangeTest(latest=float(x[-1]), latest_se=float(se[-1]), earlier_mean=mu, earlier_se=se_mu,
                      between_ride_sd=tau, difference=diff, difference_ci95=(diff - h, diff + h),
                      z=float(stat), p_value=p, verdict="changed" if p < 0.05 else "no change shown",
                      n_earlier=int(k), note=note)


def _slope(x, y) -> tuple[float | None, tuple | None]:
    """Least-squares slope of y on x with its 95 % t interval (None under three points)."""
    from scipy.stats import t as student

    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if x.size < 3 or np.ptp(x) <= 0:
        return None, None
    X = np.column_stack([np.ones_like(x), x])
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    dof = x.size - 2
    se = math.sqrt(float(np.sum((y - X @ beta) ** 2) / dof) / np.sum((x - x.mean()) ** 2))
    if not math.isfinite(se):
        return float(beta[1]), None
    h = float(student.ppf(0.975, dof)) * se
    return float(beta[1]), (float(beta[1] - h), float(beta[1] + h))


def ride_history(entries) -> RideHistory:
    """The history of one wheel's rides (:func:`ride_entry`'s, any order); WheelMismatch when
    the logs are not of one wheel.
    """
    entries = list(entries)
    zone = shared_offset(e.utc_offset_s for e in entries)
    rides = tuple(sorted(entries, key=lambda e: utc_start(e.start, e.utc_offset_s, zone)))
    check_one_wheel(rides)
    why = {}
    with_r = [e for e in rides if e.battery.resistance_ohm is not None and e.battery.resistance_ci95]
    all25 = bool(with_r) and all(e.battery.resistance_25C_ohm is not None for e in with_r)
    key, ci_key = (("resistance_25C_ohm", "resistance_25C_ci95") if all25
                   else ("resistance_ohm", "resistance_ci95"))
    change = trend = None
    if len(with_r) >= 2:
        r, ci = [getattr(e.battery, key) for e in with_r], [getattr(e.battery, ci_key) for e in with_r]
        change, trend = change_test(r, ci), trend_words(r, ci)
    else:
        why["change"] = f"{len(with_r)} ride(s) with a measured resistance: a change test needs two"
    sp = [e.summary.speed_mean_moving_mps for e in rides]
    wk = [e.summary.Wh_per_km for e in rides]
    slope, sci = _slope([np.nan if s is None else s for s in sp], [np.nan if w is None else w for w in wk])
    if slope is None:
        why["Wh_per_km_vs_speed"] = "fewer than three rides with a consumption and a speed"
    return RideHistory(rides=rides, basis="25C" if all25 else "as measured", change=change,
                       whkm_slope=slope, whkm_slope_ci95=sci, why=why, trend=trend, zone=zone)
