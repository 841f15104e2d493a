"""A ride log on a uniform grid: resampled, smoothed alike, battery power and torque.

The log is resampled onto a uniform grid under the gap policy (:func:`resample`,
:func:`ride_grid`; split, never bridged, at long gaps), smoothed and differentiated by
one Savitzky–Golay fit applied to every term of the balance (:func:`sg`; the
state-variable-filter idea of docs/identification.md), with battery power P = V·I and
the inferred motor torque (:func:`wheel_torque`).  Unknown radius and masses default to
Table 3 (:class:`RideAssumptions`).  The default window, quadratic over 1.5 s on the
10 Hz grid, has its −3 dB point near 0.7 Hz: above a rider's 0.1–0.5 Hz speed changes,
below the 2.5 Hz Nyquist frequency of 5 Hz logs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from scipy.signal import savgol_filter

from euc_sim.errors import InputError
from euc_sim.model.parameters import TABLE3, Params
from euc_sim.rides.grids.spin import spin_rows
from euc_sim.rides.source.bounds import CHANNEL_BOUNDS
from euc_sim.rides.source.gaps import GAP_POLICY, GapPolicy
from euc_sim.rides.source.ride import Ride
from euc_sim.rides.source.sanity import SPEED_SCALE_RANGE
from euc_sim.stats import label_rows

__all__ = ["RideAssumptions", "RideSignals", "with_found_values", "resample", "ride_grid", "sg", "window_samples",
           "wheel_torque", "ride_signals", "battery_power_of", "break_at_gaps", "check_readings", "split_at_gaps"]


@dataclass(frozen=True)
class RideAssumptions:
    """What a ride log does not say, with Table 3 / CONTRACT defaults.

    Attributes
    ----------
    R : float
        Wheel radius, m.
    total_mass : float
        m + m0 + mw, kg (rider, body, wheel); the normal load is total_mass·g.
    m_eq : float
        Equivalent translating mass m + m0 + mw + Jw/R², kg (eq. 13).
    g : float
        m/s².
    efficiency : float
        Drivetrain efficiency η, used only to infer torque from power.
    torque_constant : float or None
        Motor torque constant k_t, N·m/A (M = k_t·I_phase); None: torque from power.
    v_min : float
        Speeds below this, m/s, leave the torque undefined.
    sources : tuple of (str, str)
        Where ``R`` and ``total_mass`` came from; a value not listed is Table 3's.
    """

    R: float = TABLE3.R
    total_mass: float = TABLE3.total_mass
    m_eq: float = TABLE3.m_eq
    g: float = TABLE3.g
    efficiency: float = 0.8
    torque_constant: float | None = None
    v_min: float = 0.5
    sources: tuple = ()

    def __post_init__(self) -> None:
        for name in ("R", "total_mass", "m_eq", "g", "v_min"):
            val = getattr(self, name)
            if not (isinstance(val, (int, float)) and math.isfinite(val) and val > 0):
                raise InputError(f"RideAssumptions.{name} must be a positive number, got {val!r}")
        if not (0 < self.efficiency <= 1):
            raise InputError(f"RideAssumptions.efficiency must be in (0, 1], got {self.efficiency!r}")
        if self.torque_constant is not None and not self.torque_constant > 0:
            raise InputError(f"RideAssumptions.torque_constant must be positive, "
                             f"got {self.torque_constant!r}")

    @classmethod
    def from_params(cls, p: Params, **kw) -> "RideAssumptions":
        """R, total mass and m_eq from a :class:`~euc_sim.model.parameters.Params`."""
        return cls(R=p.R, total_mass=p.total_mass, m_eq=p.m_eq, g=p.g, **kw)

    def source_of(self, name: str) -> str:
        """Where the value ``name`` ("R" or "total_mass") came from."""
        return dict(self.sources).get(name, "default (Table 3)")


def ride_grid(log: Ride, policy: GapPolicy = GAP_POLICY) -> tuple[pd.DataFrame, list[str]]:
    """:func:`resample` under ``policy``, kept on the ride (built once); do not modify the frame."""
    frame, notes = log.derived(("grid", policy), lambda: resample(log, policy.rate, policy.bridge))
    return frame, list(notes)


def resample(log: Ride, rate: float = GAP_POLICY.rate,
             max_gap: float = GAP_POLICY.bridge) -> tuple[pd.DataFrame, list[str]]:
    """Resample a log onto a uniform grid, split at gaps longer than ``max_gap``.

    Parameters
    ----------
    log : Ride
    rate : float
        Grid rate, Hz; grid points are multiples of 1/rate from the log's start.
    max_gap : float
        Longest interval between samples bridged by linear interpolation, s.

    Returns
    -------
    frame : pandas.DataFrame
        ``t`` (s), ``segment`` (0-based) and every numeric channel interpolated between its
        finite samples (NaN where a segment has fewer than two); free spins left out.
    notes : list of str
        One line per split.
    """
    if rate <= 0 or max_gap <= 0:
        raise InputError(f"rate and max_gap must be positive, got rate={rate}, max_gap={max_gap}")
    d = log.data
    t = d["t"].to_numpy(float)
    if len(t) < 2:
        raise InputError(f"{log.path}: need at least two samples to resample, got {len(t)}")
    spin = spin_rows(d) if "v" in d else np.zeros(len(t), bool)
    notes = _spin_notes(t, spin, max_gap)
    rows = np.flatnonzero(~spin)
    if len(rows) < 2:
        raise InputError(f"{log.path}: column 'speed': the wheel spins off the ground on every "
                         f"row but {len(rows)}: no ride to resample")
    tk = t[rows]
    after_spin = np.diff(rows) > 1 if np.isfinite(max_gap) else np.zeros(len(rows) - 1, bool)
    cuts = np.flatnonzero((np.diff(tk) > max_gap) | after_spin)
    bounds = np.split(rows, cuts + 1)
    notes += [f"gap of {tk[i + 1] - tk[i]:.2f} s at t = {tk[i]:.2f} s (> max_gap {max_gap:g} s): "
              f"ride split there, not bridged" for i in cuts if not after_spin[i]]
    chans = [c for c in d.columns if c != "t"]
    parts = []
    for k, idx in enumerate(bounds):
        ts = t[idx]
        grid = np.arange(math.ceil(ts[0] * rate - 1e-9), math.floor(ts[-1] * rate + 1e-9) + 1) / rate
        if grid.size == 0:
            continue
        part = {"t": grid, "segment": np.full(grid.size, k)}
        for c in chans:
            y = d[c].to_numpy(float)[idx]
            ok = np.isfinite(y)
            part[c] = np.interp(grid, ts[ok], y[ok]) if ok.sum() >= 2 else np.full(grid.size, np.nan)
        parts.append(pd.DataFrame(part))
    frame = pd.concat(parts, ignore_index=True)
    return frame, notes


def _spin_notes(t: np.ndarray, spin: np.ndarray, max_gap: float) -> list[str]:
    """One line per free spin (:func:`~euc_sim.rides.grids.spin.free_spin`) left out of a grid."""
    edges = np.flatnonzero(np.diff(np.r_[0, spin.astype(int), 0]))
    how = "the ride split there" if np.isfinite(max_gap) else "bridged linearly"
    return [f"the wheel spins off the ground from t = {t[a]:.1f} to {t[b - 1]:.1f} s "
            f"({b - a} rows): left out, {how}" for a, b in zip(edges[::2], edges[1::2])]


def sg(x: np.ndarray, segment: np.ndarray, rate: float, window: float = 1.5,
       polyorder: int = 2, deriv: int = 0) -> np.ndarray:
    """Savitzky–Golay smoothing (``deriv=0``) or d/dt (``deriv=1``, per s), segment by segment.

    ``x`` on the uniform grid at ``rate`` Hz; ``window`` s is rounded to an odd number of
    samples ≥ polyorder + 2 and never crosses a ``segment`` boundary.  NaN in segments
    shorter than the window or holding a non-finite value.
    """
    x = np.asarray(x, float)
    n = window_samples(window, rate, polyorder)
    out = np.full(x.shape, np.nan)
    for m in label_rows(segment):
        if m.size < n or not np.isfinite(x[m]).all():    # e.g. a segment without GPS fix
            continue
        out[m] = savgol_filter(x[m], n, polyorder, deriv=deriv, delta=1.0 / rate, mode="interp")
    return out


def window_samples(window: float, rate: float, polyorder: int) -> int:
    n = int(round(window * rate))
    n = max(n, polyorder + 2)
    return n + 1 if n % 2 == 0 else n


def _interior(segment: np.ndarray, half: int) -> np.ndarray:
    """True for samples at least ``half`` samples from their segment's ends."""
    keep = np.zeros(np.shape(segment), bool)
    for idx in label_rows(segment):
        if idx.size > 2 * half:
            keep[idx[half: idx.size - half]] = True
    return keep


def wheel_torque(v: np.ndarray, power: np.ndarray, assumptions: RideAssumptions = RideAssumptions(),
                 phase_current: np.ndarray | None = None) -> tuple[np.ndarray, str]:
    """Motor torque on the wheel, N·m, and how it was obtained.

    ``"phase_current"``: M = k_t·I_phase, when both are known.  Else ``"power_efficiency"``:
    from battery power ``power`` (W) over ω = v/R, M = η·P/ω motoring and P/(η·ω)
    regenerating; NaN where |v| < ``v_min`` (``v`` in m/s).
    """
    v = np.asarray(v, float)
    if phase_current is not None and assumptions.torque_constant is not None:
        return assumptions.torque_constant * np.asarray(phase_current, float), "phase_current"
    P = np.asarray(power, float)
    eta = assumptions.efficiency
    with np.errstate(divide="ignore", invalid="ignore"):
        omega = v / assumptions.R
        mech = np.where(P >= 0, eta * P, P / eta)
        M = np.where(np.abs(v) >= assumptions.v_min, mech / omega, np.nan)
    return M, "power_efficiency"


@dataclass(frozen=True)
class RideSignals:
    """A ride on a uniform grid, raw and consistently smoothed.

    Attributes
    ----------
    raw : pandas.DataFrame
        Resampled, unfiltered: ``t, segment, v, P`` (battery power, W) and other channels.
    frame : pandas.DataFrame
        ``t`` s, ``segment``, ``interior`` (the filter centred), ``v`` m/s, ``a`` m/s², ``P`` W
        (all by the same filter) and ``M`` N·m (inferred torque).
    rate, window, polyorder : float, float, int
        The filter's grid rate (Hz), window (s) and degree.
    power_source, torque_method : str
        ``"voltage*current"`` or ``"power column"``; see :func:`wheel_torque`.
    notes : tuple of str
        Reader warnings and resampling notes.
    """

    path: str
    raw: pd.DataFrame
    frame: pd.DataFrame
    rate: float
    window: float
    polyorder: int
    power_source: str
    torque_method: str
    assumptions: RideAssumptions
    notes: tuple[str, ...]
    has_gps_alt: bool = False


def check_readings(log: Ride) -> None:
    """Raise ``InputError`` naming file, channel and time of a reading outside :data:`CHANNEL_BOUNDS`
    (infinite included; NaN stays) or a speed disagreeing with the odometer (:func:`odometer_scale`).
    """
    t = log.data["t"].to_numpy(float)
    for ch, (lo, hi, unit, si) in CHANNEL_BOUNDS.items():
        if ch not in log.data:
            continue
        x = log.data[ch].to_numpy(float) / si
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(np.isinf(x) | (x < lo) | (x > hi))
        if bad.size:
            i = bad[0]
            name = "speed" if ch == "v" else ch
            raise InputError(f"{log.path}: {name} = {x[i]:.3g} {unit} at t = {t[i]:.1f} s from the "
                             f"start ({bad.size} such row(s)): outside [{lo:g}, {hi:g}] {unit}, not a "
                             f"plausible reading")
    _check_speed_units(log)


#: Least odometer distance over which the speed's units are checked, m (odometers count whole m).
MIN_ODOMETER = 200.0


def odometer_scale(log: Ride) -> float | None:
    """∫|v| dt over the distance the wheel's odometer counted, on the same rows; None without one.

    About 1 for a speed in the assumed units, 0.62 for mph read as km/h.  Rows across a gap
    over the policy's ``odometer``, or where the odometer jumps or resets, are left out.
    """
    d = log.data
    col = next((c for c in ("total_distance", "distance") if c in d), None)
    if col is None or "v" not in d:
        return None
    t, v, x = (d[c].to_numpy(float) for c in ("t", "v", col))
    dt, dx = np.diff(t), np.diff(x)
    with np.errstate(invalid="ignore"):
        ok = (dt > 0) & (dt < GAP_POLICY.odometer) & np.isfinite(v[1:] + v[:-1] + dx) & (dx >= 0) & (dx < 100.0 * dt + 1.0)
    travelled = float(np.sum(dx[ok]))
    if travelled < MIN_ODOMETER:
        return None
    return float(np.sum(0.5 * (np.abs(v[1:]) + np.abs(v[:-1]))[ok] * dt[ok])) / travelled


def _check_speed_units(log: Ride) -> None:
    """Refuse a log whose speed disagrees with its own odometer (mph read as km/h: 0.62)."""
    scale = odometer_scale(log)
    if scale is not None and not SPEED_SCALE_RANGE[0] <= scale <= SPEED_SCALE_RANGE[1]:
        raise InputError(f"{log.path}: column 'speed': the speed integrates to {scale:.2f} × the "
                         f"distance the wheel's odometer counted (mph read as km/h gives 0.62): the "
                         f"speed is in other units or the distance is; convert the log to the app's units")


def ride_signals(log: Ride, assumptions: RideAssumptions = RideAssumptions(), rate: float = GAP_POLICY.rate,
                 max_gap: float = GAP_POLICY.bridge, window: float = 1.5, polyorder: int = 2) -> RideSignals:
    """Resample, smooth and differentiate a ride; battery power and inferred torque.

    The grid and filtered signals are kept on ``log``; only the torque, which depends on
    ``assumptions``, is redone.  ``rate`` Hz, ``max_gap`` s and the Savitzky–Golay
    ``window`` s and ``polyorder`` as in :func:`resample` and :func:`sg`.  ``InputError``
    without voltage and current or a power column, or when no segment fills the window.
    """
    key = ("balance", rate, max_gap, window, polyorder)
    build = lambda: _balance_grid(log, rate, max_gap, window, polyorder)   # noqa: E731
    g = log.derived(key, build)
    M, method = wheel_torque(g.frame["v"].to_numpy(), g.frame["P"].to_numpy(), assumptions, g.phase)
    notes = list(g.notes)
    if "phase_current" in g.raw and assumptions.torque_constant is None:
        notes.append("phase current present but no torque constant given: torque inferred "
                     "from power with the assumed efficiency")
    return RideSignals(path=g.path, raw=g.raw, frame=g.frame.assign(M=M), rate=rate, window=window,
                       polyorder=polyorder, power_source=g.source, torque_method=method,
                       assumptions=assumptions, notes=tuple(notes), has_gps_alt=g.has_gps_alt)


@dataclass(frozen=True)
class _BalanceGrid:
    """The balance fit's grid and filtered signals: :class:`RideSignals` less the torque."""

    path: str
    raw: pd.DataFrame
    frame: pd.DataFrame
    source: str
    phase: np.ndarray | None
    notes: tuple
    has_gps_alt: bool


def _balance_grid(log: Ride, rate: float, max_gap: float, window: float, polyorder: int) -> _BalanceGrid:
    """The balance fit's filtered grid, everything of :func:`ride_signals` but the torque."""
    check_readings(log)
    raw, notes = ride_grid(log, GapPolicy(bridge=max_gap, rate=rate))
    P, source = battery_power_of(raw)
    if P is None:
        lacking = [c for c in ("voltage", "current") if not log.has(c)]
        raise InputError(f"{log.path}: column {' and '.join(map(repr, lacking))}: absent, empty "
                         f"or all zero, and no 'power' column: battery power is needed")
    raw = raw.assign(P=P)
    n = window_samples(window, rate, polyorder)
    seg = raw["segment"].to_numpy()
    sizes = pd.Series(seg).value_counts()
    short = sizes[sizes < n]
    for s, size in short.items():
        notes.append(f"segment {s} has {size} samples, fewer than the {n}-sample filter "
                     f"window: left out")
    if len(short) == len(sizes):
        raise InputError(f"{log.path}: no stretch of the ride is as long as the {window:g} s "
                         f"filter window")
    f = lambda x, d=0: sg(x, seg, rate, window, polyorder, d)  # noqa: E731
    v = f(raw["v"].to_numpy())
    frame = pd.DataFrame({"t": raw["t"], "segment": seg,
                          "interior": _interior(seg, n // 2) & np.isfinite(v),
                          "v": v, "a": f(raw["v"].to_numpy(), 1), "P": f(P)})
    return _BalanceGrid(path=log.path, raw=raw, frame=frame, source=source,
                        phase=f(raw["phase_current"].to_numpy()) if "phase_current" in raw else None,
                        notes=tuple(log.warnings) + tuple(notes),
                        has_gps_alt="gps_alt" in raw and np.isfinite(raw["gps_alt"]).mean() > 0.5)


def battery_power_of(frame: pd.DataFrame) -> tuple[np.ndarray | None, str | None]:
    """Battery power per row, W, and its source: ``voltage × current``, else the ``power`` column, else None."""
    if "voltage" in frame and "current" in frame:
        return (frame["voltage"] * frame["current"]).to_numpy(float), "voltage*current"
    return (frame["power"].to_numpy(float), "power column") if "power" in frame else (None, None)


def break_at_gaps(t: np.ndarray, *ys: np.ndarray):
    """Insert NaN where rows are missing so a line plot does not bridge them."""
    t = np.asarray(t, float)
    if t.size < 2:
        return (t,) + tuple(np.asarray(y, float) for y in ys)
    cut = GAP_POLICY.plot_breaks(t) + 1
    out = [np.insert(t, cut, np.nan)]
    out += [np.insert(np.asarray(y, float), cut, np.nan) for y in ys]
    return tuple(out)


def with_found_values(assumptions, spec, total_mass: float | None, m_eq: float | None = None):
    """The balance fit's assumptions with the spec's radius and the mass this log gives (kg).

    A value given on the command line stays; else R comes from ``spec`` and total mass
    (m_eq, eq. 6, defaulting to it) from the log; ``sources`` says which is which.
    """
    src = dict(assumptions.sources)
    new = {}
    if "R" not in src and spec is not None and spec.radius is not None:
        new["R"] = spec.radius
        src["R"] = f"spec ({spec.name or 'wheel'}: wheel diameter)"
    m = total_mass
    if "total_mass" not in src and m is not None and m > 0:
        new["total_mass"], new["m_eq"] = m, (m_eq if m_eq is not None else m)
        src["total_mass"] = "found from this log's energy balance (total_mass)"
    return replace(assumptions, sources=tuple(src.items()), **new)


def split_at_gaps(windows, t: np.ndarray, min_len: float = 0.0) -> list[list[float]]:
    """Cut windows ``[t0, t1]`` (s) where their rows ``t`` have a gap; pieces under ``min_len`` s dropped."""
    t = np.asarray(t, float)
    if t.size < 2:
        return [list(map(float, w)) for w in windows]
    cut = GAP_POLICY.plot_breaks(t)
    starts = np.concatenate([[t[0]], t[cut + 1]])
    ends = np.concatenate([t[cut], [t[-1]]])
    out = []
    for a, b in windows:
        for s0, s1 in zip(starts, ends):
            lo, hi = max(a, s0), min(b, s1)
            if hi > lo and hi - lo >= min_len:
                out.append([float(lo), float(hi)])
    return out
