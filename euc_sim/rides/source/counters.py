"""What an app writes beside the channels: alarm flags and its own trip counters.

:func:`log_counters` takes them from the table the reader already parsed (the file is
never read again); :func:`euc_sim.rides.source.logs.read_log` keeps them on the
:class:`~euc_sim.rides.source.ride.Ride` as ``counters``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import pandas as pd

from euc_sim.rides.source.gaps import GAP_POLICY

__all__ = ["LogCounters", "log_counters", "rises", "counter_steps", "integrate_split"]


@dataclass(frozen=True)
class LogCounters:
    """What the app wrote beside the channels; None where the layout has no such column.

    Attributes
    ----------
    alarm_rows, alarm_episodes : int or None
        Rows with an alarm or alert flag set; runs of consecutive flagged rows.
    duration_s, moving_s : float or None
        The app's trip and riding clocks at the end, s.
    distance_m : float or None
        The app's trip distance (its increase, :func:`counter_steps`), m.
    speed_max_mps : float or None
        The app's top speed, m/s.
    energy_Wh : float or None
        The app's energy counter at the end, Wh.
    battery_start_pct, battery_end_pct : float or None
        The battery reading in the first and last row, %.
    battery_temp_C : float or None
        Median battery temperature, °C.
    power_Wh_drawn : float or None
        The app's ``power`` column integrated as the summary integrates V·I, Wh.
    battery_circuit_ohm : float or None
        EUC World's battery-resistance setting, Ω.
    speed_limit_mps : float or None
        The tilt-back speed set in the wheel, m/s.
    wheel_model : str or None
        ``euc.model`` and ``euc.serial`` of EUC World's ``extra`` notes.
    """

    alarm_rows: int | None = None
    alarm_episodes: int | None = None
    duration_s: float | None = None
    moving_s: float | None = None
    distance_m: float | None = None
    speed_max_mps: float | None = None
    energy_Wh: float | None = None
    battery_start_pct: float | None = None
    battery_end_pct: float | None = None
    battery_temp_C: float | None = None
    power_Wh_drawn: float | None = None
    battery_circuit_ohm: float | None = None
    speed_limit_mps: float | None = None
    wheel_model: str | None = None


def _episodes(flag: np.ndarray) -> int:
    """Runs of consecutive True values."""
    f = np.asarray(flag, bool)
    return int(f[0]) + int(np.sum(f[1:] & ~f[:-1])) if f.size else 0


def _num(raw: pd.DataFrame, col: str) -> np.ndarray | None:
    if col not in raw.columns:
        return None
    x = raw[col]
    vals = (x.to_numpy(float) if x.dtype.kind in "iuf" else
            pd.to_numeric(x.astype(str).str.strip(), errors="coerce").to_numpy(float))
    return vals if np.isfinite(vals).any() else None


def _last(x: np.ndarray | None, scale: float = 1.0) -> float | None:
    if x is None:
        return None
    f = x[np.isfinite(x)]
    return float(f[-1]) * scale if f.size else None


def log_counters(raw: pd.DataFrame, data: pd.DataFrame) -> LogCounters:
    """The alarm flags and the app's own counters of a log, from the file's ``raw`` cells and
    the reader's SI table ``data``.
    """
    flag = None
    for col in ("alarm", "alert", "Alarm", "Alert"):
        if col in raw.columns:
            flag = _raised(raw[col]) if flag is None else flag | _raised(raw[col])
    eucworld = "datetime" in raw.columns
    bat = _num(raw, "battery") if eucworld else _num(raw, "battery_level")
    bf = bat[np.isfinite(bat)] if bat is not None else np.array([])
    tb = _num(raw, "temp_batt")
    lim = _num(raw, "speed_limit")
    lim = lim[np.isfinite(lim) & (lim > 0)] if lim is not None else np.array([])
    inc = counter_steps(data)[0]
    power = (integrate_split(data["t"].to_numpy(float), data["power"].to_numpy(float))[0]
             if "power" in data else None)
    return LogCounters(
        alarm_rows=None if flag is None else int(flag.sum()),
        alarm_episodes=None if flag is None else _episodes(flag),
        duration_s=_last(_num(raw, "duration")), moving_s=_last(_num(raw, "duration_riding")),
        distance_m=None if inc is None else float(np.nansum(inc)),
        speed_max_mps=_last(_num(raw, "speed_max"), 1 / 3.6),
        energy_Wh=_last(_num(raw, "energy_consumed")),
        battery_start_pct=float(bf[0]) if bf.size else None,
        battery_end_pct=float(bf[-1]) if bf.size else None,
        battery_temp_C=float(np.nanmedian(tb)) if tb is not None else None,
        power_Wh_drawn=power,
        battery_circuit_ohm=_extra_value(raw, "euc.batteryCircuitResistance"),
        speed_limit_mps=float(lim.max()) / 3.6 if lim.size else None, wheel_model=_wheel_model(raw))


def _raised(col: pd.Series) -> np.ndarray:
    """Rows whose alarm cell is set: not empty, not 0 (nor 0.0, nan, None, null)."""
    if col.dtype.kind in "iuf":                 # numbers: any but 0 and NaN (-0.0 reads as set)
        x = col.to_numpy()
        return ~np.isnan(x) & ~((x == 0) & ~np.signbit(x)) if x.dtype.kind == "f" else x != 0
    s = col.astype(str).str.strip()
    return (~s.isin(["", "0", "0.0", "nan", "None", "null"]) & col.notna()).to_numpy()


def _extra_value(raw: pd.DataFrame, key: str) -> float | None:
    """A ``key=value`` note of EUC World's ``extra`` column, as a number."""
    if "extra" not in raw.columns:
        return None
    hit = raw["extra"].astype(str).str.extract(rf"{re.escape(key)}=([-+0-9.eE]+)")[0].dropna()
    return float(hit.iloc[-1]) if len(hit) else None


def _wheel_model(raw: pd.DataFrame) -> str | None:
    """``euc.model`` and ``euc.serial`` from EUC World's ``extra`` notes, where present."""
    if "extra" not in raw.columns:
        return None
    notes = dict(x.split("=", 1) for x in raw["extra"] if isinstance(x, str) and "=" in x)
    model = notes.get("euc.model")
    return f"{model} {notes.get('euc.serial', '')}".strip() if model else None


def rises(t: np.ndarray, x: np.ndarray, top_mps: float) -> np.ndarray:
    """Per-interval increase of a counter read ``x`` at times ``t`` (s), in its unit.

    A 5-reading running median removes bogus rows; a fall below half the previous reading
    (by more than 50) is a reset; a small fall counts nothing until the counter passes its
    highest reading; a rise faster than ``top_mps`` (+ 50) over ten intervals each side is
    bogus (NaN).  An interval ending on an empty reading is NaN; the increase across empty
    readings lands on the next reading's interval.
    """
    out = np.full(max(t.size - 1, 0), np.nan)
    idx = np.flatnonzero(np.isfinite(x))
    if idx.size < 2:
        return out
    xm = _median5(x[idx])
    reset = np.r_[False, xm[1:] < 0.5 * xm[:-1] - 50.0]
    top = (np.maximum.accumulate(xm) if not reset.any() else
           pd.Series(xm).groupby(np.cumsum(reset)).cummax().to_numpy())
    inc = np.where(reset[1:], 0.0, np.diff(top))
    ti, k = t[idx], np.arange(idx.size - 1)
    first = np.maximum.accumulate(np.where(np.r_[True, xm[1:] != xm[:-1]], np.arange(xm.size), 0))
    reach = np.maximum(ti[np.minimum(k + 11, idx.size - 1)] - ti[np.maximum(k - 10, 0)], ti[k + 1] - ti[first[k]])
    inc[inc > top_mps * reach + 50.0] = np.nan
    out[idx[1:] - 1] = inc
    return out


def _median5(x: np.ndarray) -> np.ndarray:
    """Running median of 5 finite readings, centred, of fewer at the ends (pandas'
    ``rolling(5, center=True, min_periods=1).median()``; an even count's is the mean of
    the middle two), each window sorted at once."""
    out = np.empty(x.size)
    if x.size >= 5:
        out[2:-2] = np.sort(np.lib.stride_tricks.sliding_window_view(x, 5), axis=1)[:, 2]
    for i in (range(x.size) if x.size < 5 else (0, 1, x.size - 2, x.size - 1)):
        w = np.sort(x[max(i - 2, 0):i + 3])
        out[i] = w[w.size // 2] if w.size % 2 else (w[w.size // 2 - 1] + w[w.size // 2]) / 2
    return out


def counter_steps(d: pd.DataFrame) -> tuple[np.ndarray | None, str | None]:
    """Per-interval increase of the log's own trip counter (else its odometer), m, NaN where
    it is unusable (:func:`rises`, rises faster than twice the top speed bogus), and the
    column's name; (None, None) where the log has no usable counter."""
    top = 2.0 * max(float(np.nanmax(np.abs(d["v"]))), 1.0)
    for col in ("distance", "total_distance"):
        if col in d:
            inc = rises(d["t"].to_numpy(float), d[col].to_numpy(float), top)
            if np.nansum(inc) > 0:
                return inc, col
    return None, None


def integrate_split(t: np.ndarray, p: np.ndarray) -> tuple[float | None, float | None]:
    """Trapezoid integrals of the positive and negative parts of ``p`` (W), Wh; intervals longer
    than :attr:`GapPolicy.bridge` left out."""
    dt = np.diff(t)
    good = (dt <= GAP_POLICY.bridge) & np.isfinite(p[1:]) & np.isfinite(p[:-1])
    if not good.any():
        return None, None
    pos = 0.5 * (np.clip(p[1:], 0, None) + np.clip(p[:-1], 0, None)) * dt
    neg = 0.5 * (np.clip(-p[1:], 0, None) + np.clip(-p[:-1], 0, None)) * dt
    return float(pos[good].sum() / 3600.0), float(neg[good].sum() / 3600.0)
