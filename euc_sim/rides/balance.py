"""From a ride log to what the models need, and the wheel's longitudinal balance.

A ride log (:mod:`euc_sim.rides.logs`) has wheel speed and battery voltage and
current at ~5 Hz, irregularly, and no rider lean.  This module

1. resamples it onto a uniform grid (:func:`resample`), interpolating linearly
   across gaps up to ``max_gap`` s and **splitting** the ride into segments at
   longer gaps (never bridging them);
2. smooths and differentiates with one Savitzky–Golay fit (:func:`sg`), the same
   linear filter applied to every term of the balance equation (the
   state-variable-filter idea of NOTES.md item 4);
3. computes battery power P = V·I and infers the motor torque
   (:func:`wheel_torque`), stating which method was used;
4. fits the wheel's longitudinal balance to the battery power
   (:func:`balance_design`, :func:`fit_balance`) with block-bootstrap 95 %
   intervals, flags implausible values, and compares an inertia-only model with
   an augmented one across rides (:func:`cross_ride`, :func:`ride_report`).

Balance of the whole EUC + rider along the road (no rider lean needed: the
rider's and motor's internal torques cancel)::

    m_eq·a·R = M_wheel − R·(C_rr·N·sign v + k·v|v| + m·g·sin α)

Torque is only known through battery power with an unknown efficiency, so the
balance is used in the power domain (multiply by ω = v/R).  The mechanical power
the ride demands is::

    D = m_eq·a·v + C_rr·m·g·|v| + k·|v|³ + m·g·sin α·v

and the battery supplies P = P₀ + D/η_m while motoring (D > 0) and returns
P = P₀ + η_r·D while regenerating (D ≤ 0); P₀ is a constant drain (controller,
lights), W.  A loss proportional to |P| is the same thing as lower efficiencies
and is absorbed by η_m, η_r.  The inertial power is computed as
m_eq·d/dt(v²/2) from the same Savitzky–Golay fit that smooths P and every other
regressor, so filtering commutes with the (linear) part of the equation.

Why battery power is the target (output error) and not a regressor: the motor
torque also drives the rider's lean changes (m·h·φ̈ in eq. 5, unmeasured here),
which look like noise in P; with P as a regressor (equation error m_eq·a·v =
η·P − …) that noise attenuates every coefficient (on the real rides the
efficiency came out ≈ 0.2–0.45).  Putting P on the left keeps the noise in the
target, where least squares tolerates it.  The model is linear in the
resistances but not in (η_m, η_r), so it is fitted with scipy's
``least_squares``.

Wheel radius and masses are unknown for real rides: :class:`RideAssumptions`
takes Table 3's (R = 0.2 m, m + m0 + mw = 81 kg, m_eq = 84 kg), overridable.

Window choice
-------------
WheelLog rows arrive at ~5 Hz (median interval 0.2 s, up to ~0.3 s, occasional
1 s gaps).  The grid is 10 Hz so no sample is lost, and the default
Savitzky–Golay fit is quadratic over 1.5 s (15 grid points, ~7 raw samples): by
Schafer's rule its −3 dB frequency is ≈ (p+1)/(3.2·N − 4.6)·f_s ≈ 0.7 Hz, above
the ~0.1–0.5 Hz of a rider's speed changes and well below the 2.5 Hz Nyquist
frequency of the raw data, so interpolation artefacts and the 0.01 km/h speed
quantisation are suppressed while accelerations are kept.  A longer window
lowers noise but biases accelerations (NOTES.md item 4); filtering every term
alike cancels most of that bias in the regression.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import pandas as pd
from scipy.signal import savgol_filter

from euc_sim.model.parameters import TABLE3, Params
from euc_sim.rides.logs import RideLog, read_log

__all__ = [
    "RideAssumptions", "RideSignals", "Design", "BalanceFit", "CrossRide", "CANDIDATES",
    "NOMINAL", "PLAUSIBLE", "resample", "sg", "ride_signals", "wheel_torque",
    "balance_design", "fit_balance", "plausibility", "speed_profile", "write_speed_profile",
    "cross_ride",
    "ride_report", "ride_analysis", "RideAnalysis", "plot_cross_ride",
]

RHO_AIR = 1.2  # kg/m³, air density used to turn k into a drag area


# --------------------------------------------------------------------------------------
# Assumptions
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RideAssumptions:
    """What a ride log does not say, with Table 3 / CONTRACT defaults.

    Attributes
    ----------
    R : float
        Wheel radius, m (Table 3: 0.2).
    total_mass : float
        m + m0 + mw, kg: rider, EUC body and wheel (Table 3: 81); the normal load
        is N = total_mass·g.
    m_eq : float
        Equivalent translating mass m + m0 + mw + Jw/R², kg (eq. 13; Table 3: 84).
    g : float
        m/s².
    efficiency : float
        Drivetrain efficiency η used only to *infer* torque from power
        (:func:`wheel_torque`); the regression estimates its own.
    torque_constant : float or None
        Motor torque constant k_t, N·m/A; with a phase-current channel it gives
        M = k_t·I_phase.  None: not known, torque comes from power.
    v_min : float
        Speeds below this, m/s, leave the torque undefined (P/ω blows up).
    """

    R: float = TABLE3.R
    total_mass: float = TABLE3.total_mass
    m_eq: float = TABLE3.m_eq
    g: float = TABLE3.g
    efficiency: float = 0.8
    torque_constant: float | None = None
    v_min: float = 0.5

    def __post_init__(self) -> None:
        for name in ("R", "total_mass", "m_eq", "g", "v_min"):
            val = getattr(self, name)
            if not (isinstance(val, (int, float)) and math.isfinite(val) and val > 0):
                raise ValueError(f"RideAssumptions.{name} must be a positive number, got {val!r}")
        if not (0 < self.efficiency <= 1):
            raise ValueError(f"RideAssumptions.efficiency must be in (0, 1], got {self.efficiency!r}")
        if self.torque_constant is not None and not self.torque_constant > 0:
            raise ValueError(f"RideAssumptions.torque_constant must be positive, "
                             f"got {self.torque_constant!r}")

    @classmethod
    def from_params(cls, p: Params, **kw) -> "RideAssumptions":
        """R, total mass and m_eq from a :class:`~euc_sim.model.parameters.Params`."""
        return cls(R=p.R, total_mass=p.total_mass, m_eq=p.m_eq, g=p.g, **kw)

    def as_dict(self) -> dict:
        return {"R": self.R, "total_mass": self.total_mass, "m_eq": self.m_eq, "g": self.g,
                "efficiency_for_torque": self.efficiency,
                "torque_constant": self.torque_constant, "v_min": self.v_min,
                "source": "CONTRACT / Table 3 defaults unless overridden"}


# --------------------------------------------------------------------------------------
# Resampling and filtering
# --------------------------------------------------------------------------------------
def _as_log(log) -> RideLog:
    if isinstance(log, RideLog):
        return log
    return read_log(log, emit_warnings=False)


def resample(log, rate: float = 10.0, max_gap: float = 1.0) -> tuple[pd.DataFrame, list[str]]:
    """Resample a log onto a uniform grid, split at gaps longer than ``max_gap``.

    Parameters
    ----------
    log : RideLog or path
    rate : float
        Grid rate, Hz; grid points are multiples of 1/rate from the log's start.
    max_gap : float
        Longest interval between samples, s, bridged by linear interpolation.
        Longer gaps end a segment; the next one starts after the gap.

    Returns
    -------
    frame : pandas.DataFrame
        Columns ``t`` (s), ``segment`` (int, 0-based) and every numeric channel
        of the log linearly interpolated (channels with empty cells, e.g. GPS,
        are interpolated between their finite samples; NaN where a segment has
        fewer than two).
    notes : list of str
        One line per gap split.
    """
    if rate <= 0 or max_gap <= 0:
        raise ValueError(f"rate and max_gap must be positive, got rate={rate}, max_gap={max_gap}")
    log = _as_log(log)
    d = log.data
    t = d["t"].to_numpy(float)
    if len(t) < 2:
        raise ValueError(f"{log.path}: need at least two samples to resample, got {len(t)}")
    cuts = np.flatnonzero(np.diff(t) > max_gap)
    bounds = np.split(np.arange(len(t)), cuts + 1)
    notes = [f"gap of {t[i + 1] - t[i]:.2f} s at t = {t[i]:.2f} s (> max_gap {max_gap:g} s): "
             f"ride split there, not bridged" for i in cuts]
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


def sg(x: np.ndarray, segment: np.ndarray, rate: float, window: float = 1.5,
       polyorder: int = 2, deriv: int = 0) -> np.ndarray:
    """Savitzky–Golay smoothing or derivative, applied segment by segment.

    Parameters
    ----------
    x : array_like
        Signal on the uniform grid.
    segment : array_like of int
        Segment label of each sample; the filter never crosses a boundary.
    rate : float
        Grid rate, Hz.
    window : float
        Window length, s (rounded to an odd number of samples ≥ polyorder + 2).
    polyorder : int
        Degree of the local polynomial.
    deriv : int
        0 smooths, 1 gives d/dt (unit of x per s), from the same polynomial fit.

    Returns
    -------
    numpy.ndarray
        NaN in segments shorter than the window.
    """
    x = np.asarray(x, float)
    segment = np.asarray(segment)
    n = _window_samples(window, rate, polyorder)
    out = np.full(x.shape, np.nan)
    for s in np.unique(segment):
        m = segment == s
        if m.sum() < n:
            continue
        out[m] = savgol_filter(x[m], n, polyorder, deriv=deriv, delta=1.0 / rate, mode="interp")
    return out


def _window_samples(window: float, rate: float, polyorder: int) -> int:
    n = int(round(window * rate))
    n = max(n, polyorder + 2)
    return n + 1 if n % 2 == 0 else n


def _interior(segment: np.ndarray, half: int) -> np.ndarray:
    """True for samples at least ``half`` samples from their segment's ends."""
    segment = np.asarray(segment)
    keep = np.zeros(segment.shape, bool)
    for s in np.unique(segment):
        idx = np.flatnonzero(segment == s)
        if idx.size > 2 * half:
            keep[idx[half: idx.size - half]] = True
    return keep


# --------------------------------------------------------------------------------------
# Torque
# --------------------------------------------------------------------------------------
def wheel_torque(v: np.ndarray, power: np.ndarray, assumptions: RideAssumptions = RideAssumptions(),
                 phase_current: np.ndarray | None = None) -> tuple[np.ndarray, str]:
    """Motor torque on the wheel, N·m, and how it was obtained.

    With a phase-current channel *and* a known torque constant:
    ``M = k_t·I_phase`` (method ``"phase_current"``).  Otherwise from battery power
    over wheel angular speed ω = v/R with the assumed efficiency η:
    ``M = η·P/ω`` when motoring (P·v > 0 … P > 0) and ``M = P/(η·ω)`` when
    regenerating (P < 0); undefined (NaN) where |v| < ``v_min``
    (method ``"power_efficiency"``).

    Parameters
    ----------
    v : array_like
        Wheel speed, m/s.
    power : array_like
        Battery power, W (positive drawn from the battery).
    assumptions : RideAssumptions
    phase_current : array_like, optional
        Motor phase current, A.

    Returns
    -------
    M : numpy.ndarray
        N·m.
    method : str
        ``"phase_current"`` or ``"power_efficiency"``.
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


# --------------------------------------------------------------------------------------
# Signals
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RideSignals:
    """A ride on a uniform grid, raw and consistently smoothed.

    Attributes
    ----------
    path : str
    raw : pandas.DataFrame
        Resampled, unfiltered: ``t, segment, v, P`` (battery power, W) and the
        log's other channels.
    frame : pandas.DataFrame
        ``t`` s, ``segment``, ``interior`` (bool: far enough from a segment end
        for the filter to be centred), ``v`` m/s, ``a`` m/s², ``P`` W (all
        smoothed by the same Savitzky–Golay fit), ``M`` N·m (inferred torque).
    rate, window : float
        Hz, s.
    polyorder : int
    power_source : str
        ``"voltage*current"`` or ``"power column"``.
    torque_method : str
        See :func:`wheel_torque`.
    assumptions : RideAssumptions
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

    def filt(self, x, deriv: int = 0) -> np.ndarray:
        """The signals' Savitzky–Golay filter applied to another grid signal."""
        return sg(x, self.raw["segment"].to_numpy(), self.rate, self.window, self.polyorder, deriv)


def ride_signals(log, assumptions: RideAssumptions = RideAssumptions(), rate: float = 10.0,
                 max_gap: float = 1.0, window: float = 1.5, polyorder: int = 2) -> RideSignals:
    """Resample, smooth and differentiate a ride; battery power and inferred torque.

    Parameters
    ----------
    log : RideLog or path
    assumptions : RideAssumptions
    rate : float
        Grid rate, Hz.
    max_gap : float
        Longest gap bridged, s (see :func:`resample`).
    window : float
        Savitzky–Golay window, s (module docstring: why 1.5 s for ~5 Hz logs).
    polyorder : int

    Returns
    -------
    RideSignals

    Raises
    ------
    ValueError
        when the log has neither voltage and current nor a power column, or no
        segment is as long as the filter window.
    """
    log = _as_log(log)
    raw, notes = resample(log, rate, max_gap)
    if log.has("voltage") and log.has("current"):
        P = raw["voltage"].to_numpy() * raw["current"].to_numpy()
        source = "voltage*current"
    elif log.has("power"):
        P = raw["power"].to_numpy()
        source = "power column"
    else:
        raise ValueError(f"{log.path}: no battery power: need columns voltage and current, "
                         f"or power")
    raw = raw.assign(P=P)
    n = _window_samples(window, rate, polyorder)
    seg = raw["segment"].to_numpy()
    sizes = pd.Series(seg).value_counts()
    short = sizes[sizes < n]
    for s, size in short.items():
        notes.append(f"segment {s} has {size} samples, fewer than the {n}-sample filter "
                     f"window: left out")
    if len(short) == len(sizes):
        raise ValueError(f"{log.path}: no stretch of the ride is as long as the {window:g} s "
                         f"filter window")
    f = lambda x, d=0: sg(x, seg, rate, window, polyorder, d)  # noqa: E731
    v = f(raw["v"].to_numpy())
    a = f(raw["v"].to_numpy(), 1)
    Ps = f(P)
    phase = f(raw["phase_current"].to_numpy()) if "phase_current" in raw else None
    M, method = wheel_torque(v, Ps, assumptions, phase)
    if "phase_current" in raw and assumptions.torque_constant is None:
        notes.append("phase current present but no torque constant given: torque inferred "
                     "from power with the assumed efficiency")
    frame = pd.DataFrame({"t": raw["t"], "segment": seg,
                          "interior": _interior(seg, n // 2) & np.isfinite(v),
                          "v": v, "a": a, "P": Ps, "M": M})
    return RideSignals(path=log.path, raw=raw, frame=frame, rate=rate, window=window,
                       polyorder=polyorder, power_source=source, torque_method=method,
                       assumptions=assumptions, notes=tuple(log.warnings) + tuple(notes),
                       has_gps_alt="gps_alt" in raw and np.isfinite(raw["gps_alt"]).mean() > 0.5)


def speed_profile(log, rate: float = 10.0, window: float = 1.5, polyorder: int = 2) -> pd.DataFrame:
    """The logged wheel speed as a simulator input: ``DataFrame(t, v)``.

    Uniform grid at ``rate`` Hz from t = 0, speed in m/s smoothed by the same
    Savitzky–Golay fit as :func:`ride_signals`.  **Every gap is bridged** by linear
    interpolation here (a simulation needs a continuous profile); the gaps
    bridged are listed in ``result.attrs["notes"]``.

    Parameters
    ----------
    log : RideLog or path
    rate : float
        Hz.
    window : float
        s.
    polyorder : int

    Returns
    -------
    pandas.DataFrame
        Columns ``t`` (s, strictly increasing) and ``v`` (m/s).
    """
    log = _as_log(log)
    raw, _ = resample(log, rate, max_gap=math.inf)
    t = log.data["t"].to_numpy()
    gaps = np.flatnonzero(np.diff(t) > 1.0)
    v = sg(raw["v"].to_numpy(), np.zeros(len(raw), int), rate, window, polyorder)
    out = pd.DataFrame({"t": raw["t"].to_numpy(), "v": v})
    out.attrs["notes"] = [f"gap of {t[i + 1] - t[i]:.2f} s at t = {t[i]:.2f} s bridged linearly"
                          for i in gaps]
    out.attrs["source"] = log.path
    return out


def write_speed_profile(log, path, rate: float = 10.0, window: float = 1.5) -> Path:
    """Write :func:`speed_profile` as a CSV (``t,v``) atomically, for the simulator.

    Returns
    -------
    pathlib.Path
    """
    from euc_sim.io import atomic_write

    prof = speed_profile(log, rate, window)
    return atomic_write(path, lambda p: prof.to_csv(p, index=False, float_format="%.6f"))


# --------------------------------------------------------------------------------------
# The balance regression
# --------------------------------------------------------------------------------------
#: Candidate parameters: name -> (symbol, unit, meaning, regressor column or None, column unit).
CANDIDATES: dict[str, tuple[str, str, str, str | None, str | None]] = {
    "eta_motor": ("η_m", "1", "drivetrain efficiency while motoring (battery to wheel)",
                  None, None),
    "eta_regen": ("η_r", "1", "drivetrain efficiency while regenerating (wheel to battery)",
                  None, None),
    "rolling_resistance": ("C_rr", "1", "rolling-resistance coefficient, force C_rr·N·sign v",
                           "rolling", "W"),
    "aerodynamic_drag": ("k", "kg/m", "drag factor ½ρC_dA, force k·v|v|", "drag", "m³/s³"),
    "road_slope": ("sin α", "1", "constant road grade, force m·g·sin α", "slope", "W"),
    "road_slope_gps": ("gain", "1", "gain on m·g·dh/dt from GPS altitude (1 if GPS is right)",
                       "gps_climb", "W"),
    "drivetrain_idle_loss": ("P₀", "W", "constant electrical drain (controller, lights)",
                             None, None),
}
#: The inertia-only model: the paper's balance with no resistance, plus the two
#: efficiencies without which battery power cannot be compared at all.
NOMINAL = ("eta_motor", "eta_regen")
#: Start values and bounds of the least-squares fit.
_START = {"eta_motor": 0.8, "eta_regen": 0.8, "rolling_resistance": 0.0,
          "aerodynamic_drag": 0.0, "road_slope": 0.0, "road_slope_gps": 1.0,
          "drivetrain_idle_loss": 0.0}
_BOUNDS = {"eta_motor": (0.05, 5.0), "eta_regen": (0.0, 5.0)}

#: Plausible ranges of the physical estimates, with units.
PLAUSIBLE: dict[str, tuple[float, float, str]] = {
    "rolling_resistance": (0.005, 0.05, "1"),
    "aerodynamic_drag": (0.5 * RHO_AIR * 0.3, 0.5 * RHO_AIR * 1.0, "kg/m"),   # C_dA 0.3-1.0 m²
    "eta_motor": (0.5, 0.95, "1"),
    "eta_regen": (0.5, 0.95, "1"),
    "road_slope": (-0.15, 0.15, "1"),
    "road_slope_gps": (0.5, 1.5, "1"),
    "drivetrain_idle_loss": (0.0, 100.0, "W"),
}


@dataclass(frozen=True)
class Design:
    """A ride's longitudinal balance, ready to fit: target and named regressors.

    Model (power domain, W)::

        D = inertia + C_rr·rolling + k·drag + sin α·slope + gain·gps_climb
        g(D) = D/η_m   where D > 0 (motoring),   D·η_r   where D ≤ 0 (regenerating)
        P̂ = P₀ + L₂[g(D)]

    Filtering.  Every regressor is first passed through a short Savitzky–Golay
    fit L₁ (``inertia`` through its derivative); the regime switch g acts on
    those; then one longer Savitzky–Golay fit L₂ smooths the prediction.  The
    measured battery power gets exactly L₂∘L₁.  Within a regime the model is
    linear, so both sides then carry the same linear filter L₂∘L₁; only where D
    changes sign does the (short) L₁ smear the switch.  (Applying the long
    filter before the switch biases η_m low and η_r high by a few per cent,
    since smoothing a convex kink raises it: Jensen.)

    Attributes
    ----------
    columns_full : pandas.DataFrame
        On the whole grid, L₁-filtered: ``inertia`` = m_eq·d/dt(v²/2), W;
        ``rolling`` = m·g·|v|, W; ``drag`` = |v|³, m³/s³; ``slope`` = m·g·v, W
        (only when v changes sign); ``gps_climb`` = m·g·dh/dt, W (only with GPS
        altitude).
    P_full : numpy.ndarray
        Battery power V·I filtered by L₂∘L₁, W (NaN near segment ends).
    segment : numpy.ndarray of int
    use : numpy.ndarray of bool
        Rows that enter the residual.
    kernel : numpy.ndarray
        L₂'s convolution coefficients.
    weight_full : numpy.ndarray
        Residual weight: 1 (``domain="power"``), or R/v, s (``"torque"``:
        residuals become battery-side torque errors, N·m).
    t_full, v_full : numpy.ndarray
        s; L₂∘L₁-smoothed speed, m/s.
    domain, unit : str
        ``"power"``/``"W"`` or ``"torque"``/``"N·m"``.
    candidates : tuple of str
        Parameters this ride supports (keys of :data:`CANDIDATES`).
    aliases : dict
        Candidate -> candidates this ride cannot tell apart from it.
    notes : tuple of str
    path : str
    """

    columns_full: pd.DataFrame
    P_full: np.ndarray
    segment: np.ndarray
    use: np.ndarray
    kernel: np.ndarray
    weight_full: np.ndarray
    t_full: np.ndarray
    v_full: np.ndarray
    domain: str
    unit: str
    candidates: tuple[str, ...]
    aliases: Mapping[str, tuple[str, ...]]
    notes: tuple[str, ...]
    path: str = ""

    # rows in use --------------------------------------------------------------
    @property
    def P(self) -> np.ndarray:
        """Measured (filtered) battery power on the rows in use, W."""
        return self.P_full[self.use]

    @property
    def t(self) -> np.ndarray:
        return self.t_full[self.use]

    @property
    def v(self) -> np.ndarray:
        return self.v_full[self.use]

    @property
    def weight(self) -> np.ndarray:
        return self.weight_full[self.use]

    def rows(self, mask: np.ndarray) -> "Design":
        """The same design with fewer rows in use (``mask`` over the rows in use)."""
        use = self.use.copy()
        use[np.flatnonzero(self.use)[~np.asarray(mask, bool)]] = False
        return replace(self, use=use)

    def predict(self, params: Mapping[str, float]) -> np.ndarray:
        """Battery power P̂, W, on the rows in use (missing resistances are 0)."""
        D = self.columns_full["inertia"].to_numpy().copy()
        for name, (_, _, _, col, _) in CANDIDATES.items():
            if col is not None and name in params:
                D += params[name] * self.columns_full[col].to_numpy()
        g = np.where(D > 0, D / params["eta_motor"], D * params["eta_regen"])
        return params.get("drivetrain_idle_loss", 0.0) + _conv(g, self.segment, self.kernel)[self.use]

    def residual(self, params: Mapping[str, float], target: np.ndarray | None = None) -> np.ndarray:
        """Weighted residual (measured − predicted) on the rows in use, W or N·m."""
        P = self.P if target is None else target
        return self.weight * (P - self.predict(params))


def _conv(x: np.ndarray, segment: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Convolve each segment with ``kernel``; NaN where the kernel overhangs an end."""
    out = np.full(x.shape, np.nan)
    half = len(kernel) // 2
    for s in np.unique(segment):
        idx = np.flatnonzero(segment == s)
        if idx.size < len(kernel):
            continue
        y = np.convolve(x[idx], kernel, mode="same")
        y[:half] = np.nan
        y[idx.size - half:] = np.nan
        out[idx] = y
    return out


#: Short pre-filter L₁ applied to every regressor before the regime switch, s.
PRE_WINDOW = 0.5


def balance_design(sig: RideSignals, domain: str = "power",
                   sign_change_fraction: float = 0.02, pre_window: float = PRE_WINDOW) -> Design:
    """The longitudinal balance of a ride, every term filtered alike.

    ``road_slope`` (a constant grade) is offered only when the speed changes sign
    on at least ``sign_change_fraction`` of the moving samples: otherwise its
    column m·g·v equals the rolling-resistance column m·g·|v| and the two alias
    exactly (NOTES.md item 5); the design then says so in ``aliases`` and the
    rolling-resistance estimate stands for C_rr + sin α.  ``road_slope_gps`` needs
    GPS altitude.

    Parameters
    ----------
    sig : RideSignals
        Its ``window`` and ``polyorder`` give the main filter L₂.
    domain : {"power", "torque"}
        Residuals in W, or divided by ω = v/R (rows with |v| ≥ v_min) in N·m.
    sign_change_fraction : float
    pre_window : float
        Window of the short pre-filter L₁, s (see :class:`Design`).

    Returns
    -------
    Design
    """
    from scipy.signal import savgol_coeffs

    if domain not in ("power", "torque"):
        raise ValueError(f"domain must be 'power' or 'torque', got {domain!r}")
    A = sig.assumptions
    mg = A.total_mass * A.g
    raw = sig.raw
    seg = raw["segment"].to_numpy()
    v_raw = raw["v"].to_numpy()
    p1 = min(2, sig.polyorder)
    L1 = lambda x, d=0: sg(x, seg, sig.rate, pre_window, p1, d)  # noqa: E731
    n2 = _window_samples(sig.window, sig.rate, sig.polyorder)
    kernel = savgol_coeffs(n2, sig.polyorder)
    L2 = lambda x: _conv(x, seg, kernel)  # noqa: E731
    notes: list[str] = []
    cols = {
        "inertia": A.m_eq * L1(0.5 * v_raw ** 2, 1),       # m_eq·a·v = m_eq·d/dt(v²/2)
        "rolling": mg * L1(np.abs(v_raw)),
        "drag": L1(np.abs(v_raw) ** 3),
    }
    cands = ["eta_motor", "eta_regen", "rolling_resistance", "aerodynamic_drag",
             "drivetrain_idle_loss"]
    aliases: dict[str, tuple[str, ...]] = {}
    moving = np.abs(v_raw) > 0.3
    back = float((v_raw[moving] < -0.3).mean()) if moving.any() else 0.0
    fwd = float((v_raw[moving] > 0.3).mean()) if moving.any() else 0.0
    if min(back, fwd) >= sign_change_fraction:
        cols["slope"] = mg * L1(v_raw)
        cands.append("road_slope")
    else:
        aliases["rolling_resistance"] = ("road_slope",)
        aliases["road_slope"] = ("rolling_resistance",)
        notes.append(f"the speed keeps one sign ({100 * min(back, fwd):.1f} % of moving samples "
                     f"the other way): rolling resistance and a constant road slope give the "
                     f"same column, so only C_rr + sin α is estimated (as rolling_resistance)")
    if sig.has_gps_alt:
        cols["gps_climb"] = mg * L1(raw["gps_alt"].to_numpy(), 1)
        cands.append("road_slope_gps")
    else:
        notes.append("no GPS altitude: road grade unknown; a varying grade stays in the residual")
    X = pd.DataFrame(cols)
    P = L2(L1(raw["P"].to_numpy()))
    v = L2(L1(v_raw))
    weight = np.ones_like(P)
    unit = "W"
    use = np.isfinite(P) & np.isfinite(X.to_numpy()).all(axis=1) & np.isfinite(v)
    if domain == "torque":
        with np.errstate(divide="ignore", invalid="ignore"):
            weight = A.R / v
        use &= np.abs(v) >= A.v_min
        unit = "N·m"
    X = X.fillna(0.0)             # rows out of use; keeps the convolution finite inside
    return Design(columns_full=X, P_full=P, segment=seg, use=use, kernel=kernel,
                  weight_full=weight, t_full=raw["t"].to_numpy(), v_full=v, domain=domain,
                  unit=unit, candidates=tuple(cands), aliases=aliases, notes=tuple(notes),
                  path=sig.path)


@dataclass(frozen=True)
class BalanceFit:
    """A least-squares fit of a :class:`Design`, with block-bootstrap intervals.

    Attributes
    ----------
    names : tuple of str
        Fitted parameters (keys of :data:`CANDIDATES`).
    estimate : dict
        Value of each, in the unit of :data:`CANDIDATES`.
    ci95 : dict
        95 % percentile intervals from a moving-block residual bootstrap.
    se_naive : dict
        Standard errors from the Jacobian, assuming independent residuals (they
        are not: shown for comparison only).
    rmse : float
        In-sample RMS weighted residual, W or N·m.
    n : int
        Rows used.
    n_boot, block_s, seed :
        Bootstrap settings.
    unit : str
    boot_corr : dict
        Correlation of the bootstrap replicates of each pair of parameters,
        ``{(a, b): r}``; |r| near 1 means this ride cannot tell a from b.
    """

    names: tuple[str, ...]
    estimate: Mapping[str, float]
    ci95: Mapping[str, tuple[float, float]]
    se_naive: Mapping[str, float]
    rmse: float
    n: int
    n_boot: int
    block_s: float
    seed: int
    unit: str = "W"
    boot_corr: Mapping[tuple[str, str], float] = None

    def confounded(self, name: str, threshold: float = 0.8) -> tuple[str, ...]:
        """Parameters whose bootstrap replicates correlate with ``name``'s beyond ±threshold."""
        if not self.boot_corr:
            return ()
        return tuple(b for (a, b), r in self.boot_corr.items()
                     if a == name and b != name and abs(r) >= threshold)

    def rmse_on(self, design: Design) -> float:
        """RMS weighted residual of this fit on another design, W or N·m."""
        r = design.residual(self.estimate)
        return float(np.sqrt(np.mean(r ** 2)))


def _solve(design: Design, names: Sequence[str], x0: np.ndarray, P: np.ndarray | None = None):
    from scipy.optimize import least_squares

    lo = np.array([_BOUNDS.get(n, (-np.inf, np.inf))[0] for n in names])
    hi = np.array([_BOUNDS.get(n, (-np.inf, np.inf))[1] for n in names])
    scale = np.array([{"drivetrain_idle_loss": 10.0, "aerodynamic_drag": 0.1,
                       "rolling_resistance": 0.01, "road_slope": 0.01}.get(n, 0.1) for n in names])
    res = least_squares(lambda th: design.residual(dict(zip(names, th)), P), np.clip(x0, lo + 1e-9, hi - 1e-9),
                        bounds=(lo, hi), x_scale=scale, method="trf")
    return res


def fit_balance(design: Design, names: Sequence[str] | None = None, n_boot: int = 200,
                block_s: float = 10.0, seed: int = 0) -> BalanceFit:
    """Least squares (scipy ``least_squares``) with moving-block bootstrap 95 % intervals.

    Residuals of a ride are autocorrelated (the filter; an unknown, varying road
    grade; the rider's lean, which the motor must also drive), so the bootstrap
    resamples contiguous blocks of ``block_s`` seconds of residuals, adds them to
    the fitted power and refits; the intervals are the 2.5 and 97.5 percentiles.
    Draws use ``numpy.random.default_rng(seed)``.

    Parameters
    ----------
    design : Design
    names : sequence of str, optional
        Parameters to fit (default: all of ``design.candidates``); the two
        efficiencies are always included.
    n_boot : int
        Bootstrap replicates (0: no intervals, NaN).
    block_s : float
        Block length, s.
    seed : int

    Returns
    -------
    BalanceFit
    """
    names = list(names) if names is not None else list(design.candidates)
    for n in NOMINAL:
        if n not in names:
            names.insert(NOMINAL.index(n), n)
    bad = [n for n in names if n not in design.candidates]
    if bad:
        raise ValueError(f"parameter {bad[0]!r} is not available on {design.path or 'this ride'} "
                         f"(available: {', '.join(design.candidates)})")
    n = len(design.P)
    if n <= len(names) + 2:
        raise ValueError(f"{design.path}: {n} usable rows, too few for {len(names)} parameters")
    x0 = np.array([_START[k] for k in names])
    res = _solve(design, names, x0)
    theta = res.x
    est = dict(zip(names, map(float, theta)))
    e = res.fun
    fitted_P = design.predict(est)
    # Unweighted residuals in P units are what gets resampled.
    e_P = design.P - fitted_P
    J = res.jac
    dof = max(n - len(names), 1)
    try:
        cov = (e @ e) / dof * np.linalg.pinv(J.T @ J)
        se = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        se = np.full(len(names), np.nan)
    dt = float(np.median(np.diff(design.t))) if n > 1 else 0.1
    L = max(1, min(n, int(round(block_s / dt)))) if dt > 0 else 1
    rng = np.random.default_rng(seed)
    n_blocks = int(math.ceil(n / L))
    boots = np.empty((n_boot, len(names)))
    for i in range(n_boot):
        starts = rng.integers(0, n - L + 1, size=n_blocks)
        e_star = np.concatenate([e_P[s:s + L] for s in starts])[:n]
        boots[i] = _solve(design, names, theta, P=fitted_P + e_star).x
    corr = {}
    if n_boot:
        lo, hi = np.percentile(boots, [2.5, 97.5], axis=0)
        if n_boot > 2:
            with np.errstate(invalid="ignore", divide="ignore"):
                C = np.corrcoef(boots, rowvar=False)
            corr = {(a, b): float(C[i, j]) for i, a in enumerate(names)
                    for j, b in enumerate(names) if i != j and np.isfinite(C[i, j])}
    else:
        lo = hi = np.full(len(names), np.nan)
    return BalanceFit(names=tuple(names), estimate=est,
                      ci95={k: (float(a), float(b)) for k, a, b in zip(names, lo, hi)},
                      se_naive=dict(zip(names, map(float, se))),
                      rmse=float(np.sqrt(np.mean(e ** 2))), n=n, n_boot=n_boot,
                      block_s=block_s, seed=seed, unit=design.unit, boot_corr=corr)


def plausibility(fit: BalanceFit) -> dict[str, dict]:
    """Physical estimates of a fit, with units, intervals and plausibility flags.

    Adds the drag area C_dA = 2k/ρ (ρ = 1.2 kg/m³) and the road angle
    α = arcsin(sin α) where they apply.

    Returns
    -------
    dict
        name -> {"estimate", "unit", "ci95", "plausible_range", "plausible": bool,
        "symbol", "meaning"}; ``plausible`` is False when the estimate lies outside
        :data:`PLAUSIBLE`.
    """
    out: dict[str, dict] = {}
    for k in fit.names:
        est, ci = fit.estimate[k], list(fit.ci95[k])
        sym, unit, meaning, _, _ = CANDIDATES[k]
        rng = PLAUSIBLE.get(k)
        entry = {"estimate": est, "unit": unit, "ci95": ci, "symbol": sym, "meaning": meaning,
                 "plausible_range": list(rng[:2]) if rng else None,
                 "plausible": bool(rng is None or rng[0] <= est <= rng[1])}
        if k == "aerodynamic_drag":
            entry["drag_area_m2"] = 2 * est / RHO_AIR
            entry["drag_area_m2_ci95"] = [2 * c / RHO_AIR for c in ci]
        if k == "road_slope":
            entry["angle_rad"] = math.asin(max(-1.0, min(1.0, est)))
        out[k] = entry
    return out


# --------------------------------------------------------------------------------------
# Cross-ride comparison and the report
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CrossRide:
    """Inertia-only against augmented balance, fitted on one ride, tested on another.

    Attributes
    ----------
    nominal, full, augmented : BalanceFit
        Fits on the fit ride: inertia only (η_m, η_r); every candidate the ride
        supports; nominal plus the accepted effects.
    accepted : tuple of str
        Effects whose full-fit 95 % interval excludes zero on the physical side,
        strongest (largest in-sample improvement alone) first.
    heldout_nominal, heldout_augmented, heldout_full : float
        RMS residual on the test ride, W or N·m.
    """

    fit_design: Design
    test_design: Design
    nominal: BalanceFit
    full: BalanceFit
    augmented: BalanceFit
    accepted: tuple[str, ...]
    heldout_nominal: float
    heldout_augmented: float
    heldout_full: float
    fit_label: str
    test_label: str

    @property
    def ratio(self) -> float:
        """heldout_augmented / heldout_nominal (< 1: the augmented model predicts better)."""
        return self.heldout_augmented / self.heldout_nominal


def cross_ride(fit_design: Design, test_design: Design, n_boot: int = 200, block_s: float = 10.0,
               seed: int = 0, fit_label: str = "fit", test_label: str = "test") -> CrossRide:
    """Fit the nominal and augmented balances on one design, measure both on another.

    An effect is *accepted* when its 95 % interval in the full fit excludes zero on
    the physical side (C_rr, k, P₀ > 0; a slope or GPS gain of either sign).
    """
    common = [c for c in fit_design.candidates if c in test_design.candidates]
    nominal = fit_balance(fit_design, list(NOMINAL), n_boot, block_s, seed)
    full = fit_balance(fit_design, common, n_boot, block_s, seed)
    accepted = []
    for c in full.names:
        if c in NOMINAL:
            continue
        lo, hi = full.ci95[c]
        if (lo > 0) or (c.startswith("road_slope") and hi < 0):
            accepted.append(c)
    alone = sorted(accepted, key=lambda c: fit_balance(fit_design, list(NOMINAL) + [c], 0).rmse)
    augmented = fit_balance(fit_design, list(NOMINAL) + alone, n_boot, block_s, seed)
    return CrossRide(fit_design=fit_design, test_design=test_design, nominal=nominal, full=full,
                     augmented=augmented, accepted=tuple(alone),
                     heldout_nominal=nominal.rmse_on(test_design),
                     heldout_augmented=augmented.rmse_on(test_design),
                     heldout_full=full.rmse_on(test_design),
                     fit_label=fit_label, test_label=test_label)


def _effects(cr: CrossRide) -> list[dict]:
    """CONTRACT's effect entries for the accepted effects, strongest first."""
    out = []
    cum = list(NOMINAL)
    phys = plausibility(cr.augmented)
    for c in cr.accepted:
        cum.append(c)
        rmse_after = fit_balance(cr.fit_design, cum, n_boot=0).rmse
        ph = phys[c]
        exact = list(cr.fit_design.aliases.get(c, ()))
        confounded = [x for x in cr.full.confounded(c) if x not in exact]
        aliases = exact + confounded
        ev = (f"adding {ph['symbol']} ({ph['meaning']}) lowers the RMS battery-power residual "
              f"on {cr.fit_label} from {cr.nominal.rmse:.0f} to {rmse_after:.0f} {cr.nominal.unit}, "
              f"95% interval {ph['ci95'][0]:.3g} to {ph['ci95'][1]:.3g} {ph['unit']}")
        if exact:
            ev += (f"; the speed never changes sign, so it is the sum of this and "
                   f"{' and '.join(exact)} (a constant road grade looks the same)")
        if confounded:
            ev += (f"; in the fit with every candidate its estimate trades off against "
                   f"{' and '.join(confounded)} (bootstrap correlation beyond ±0.8): this ride "
                   f"cannot tell them apart")
        if not ph["plausible"]:
            ev += (f"; OUTSIDE the plausible range {ph['plausible_range'][0]:g} to "
                   f"{ph['plausible_range'][1]:g} {ph['unit']}: it also absorbs something else")
        entry = {"name": c, "estimate": ph["estimate"], "unit": ph["unit"], "ci95": ph["ci95"],
                 "rmse_after": rmse_after, "aliases": aliases, "evidence": ev,
                 "plausible": ph["plausible"], "plausible_range": ph["plausible_range"]}
        for extra in ("drag_area_m2", "drag_area_m2_ci95", "angle_rad"):
            if extra in ph:
                entry[extra] = ph[extra]
        out.append(entry)
    return out


def _broken(t: np.ndarray, *ys: np.ndarray):
    """Insert NaN where rows are missing so a line plot does not bridge them."""
    t = np.asarray(t, float)
    if t.size < 2:
        return (t,) + tuple(np.asarray(y, float) for y in ys)
    step = np.median(np.diff(t))
    cut = np.flatnonzero(np.diff(t) > 1.5 * step) + 1
    out = [np.insert(t, cut, np.nan)]
    out += [np.insert(np.asarray(y, float), cut, np.nan) for y in ys]
    return tuple(out)


def plot_cross_ride(cr: CrossRide, path, sig_fit: RideSignals | None = None,
                    sig_test: RideSignals | None = None) -> Path:
    """Figure: the test ride's battery power, inertia-only against augmented prediction.

    Panels: (1) wheel speed of both rides, m/s; (2) on the test ride, the measured
    battery power against both models' predictions (parameters from the fit
    ride), W; (3) their residuals with RMS values and the ratio.  PNG, written
    atomically (matplotlib Agg).
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from euc_sim.io import atomic_write

    td = cr.test_design
    pn = td.predict(cr.nominal.estimate)
    pa = td.predict(cr.augmented.estimate)
    fig, ax = plt.subplots(3, 1, figsize=(11, 9.5))
    if sig_fit is not None:
        ax[0].plot(*_broken(sig_fit.frame["t"], sig_fit.frame["v"]), lw=0.8,
                   label=f"{cr.fit_label} (fit)")
    if sig_test is not None:
        ax[0].plot(*_broken(sig_test.frame["t"], sig_test.frame["v"]), lw=0.8,
                   label=f"{cr.test_label} (test)")
    ax[0].set(ylabel="wheel speed v [m/s]", xlabel="time from start of log [s]",
              title="Logged wheel speed (10 Hz grid, Savitzky–Golay 1.5 s)")
    ax[0].legend(loc="upper right", fontsize=8)
    nom = cr.nominal.estimate
    aug = cr.augmented.estimate
    tt, P_b, pn_b, pa_b = _broken(td.t, td.P, pn, pa)
    ax[1].plot(tt, P_b, color="k", lw=0.9, label="measured battery power V·I")
    ax[1].plot(tt, pn_b, lw=0.8, label=f"inertia only (η_m={nom['eta_motor']:.2f}, "
                                       f"η_r={nom['eta_regen']:.2f})")
    sym = lambda c: CANDIDATES[c][0] + ("+sin α" if c == "rolling_resistance"  # noqa: E731
                                        and cr.fit_design.aliases.get(c) else "")
    lab = ", ".join(f"{sym(c)}={aug[c]:.3g}" for c in cr.accepted) or "nothing accepted"
    ax[1].plot(tt, pa_b, lw=0.8, label=f"augmented ({lab})")
    ax[1].set(ylabel="battery power [W]", xlabel="time from start of log [s]",
              title=f"{cr.test_label}: predicted from its speed with parameters fitted on "
                    f"{cr.fit_label}")
    ax[1].legend(loc="upper right", fontsize=8)
    rn = td.weight * (td.P - pn)           # W, or N·m in the torque domain
    ra = td.weight * (td.P - pa)
    tt, rn, ra = _broken(td.t, rn, ra)
    ax[2].plot(tt, rn, lw=0.7, label=f"inertia only: RMS {cr.heldout_nominal:.0f} {td.unit}")
    ax[2].plot(tt, ra, lw=0.7, label=f"augmented: RMS {cr.heldout_augmented:.0f} {td.unit}")
    ax[2].axhline(0, color="grey", lw=0.5)
    what = "measured − predicted" if td.domain == "power" else "(measured − predicted)·R/v"
    ax[2].set(ylabel=f"{what} [{td.unit}]", xlabel="time from start of log [s]",
              title=f"Held-out residual; error ratio augmented / inertia-only = {cr.ratio:.2f}")
    ax[2].legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    try:
        return atomic_write(path, lambda p: fig.savefig(p, dpi=110, format="png"))
    finally:
        plt.close(fig)


@dataclass(frozen=True)
class RideAnalysis:
    """What :func:`ride_analysis` computed: the JSON report and the objects behind it.

    Attributes
    ----------
    report : dict
        CONTRACT's ``euc-sim ride`` form (see :func:`ride_report`).
    cross : CrossRide
    sig_fit, sig_test : RideSignals
        The fit ride and the compare ride (None without ``compare_path``).
    """

    report: dict
    cross: CrossRide
    sig_fit: RideSignals
    sig_test: RideSignals | None


def ride_report(log_path, compare_path=None, **kwargs) -> dict:
    """Diagnose a ride's longitudinal balance; CONTRACT's ``euc-sim ride`` JSON form.

    ``ride_analysis(log_path, compare_path, **kwargs).report``: see :func:`ride_analysis`.
    """
    return ride_analysis(log_path, compare_path, **kwargs).report


def ride_analysis(log_path, compare_path=None, *, report_dir=None,
                  assumptions: RideAssumptions = RideAssumptions(), rate: float = 10.0,
                  max_gap: float = 1.0, window: float = 1.5, polyorder: int = 2,
                  domain: str = "power", n_boot: int = 200, block_s: float = 10.0,
                  seed: int = 0) -> RideAnalysis:
    """Diagnose a ride's longitudinal balance; CONTRACT's ``euc-sim ride`` JSON form.

    Fits the inertia-only balance (η_m, η_r) and the augmented one on
    ``log_path`` and measures both on ``compare_path``; without ``compare_path``
    the first half of the ride is the fit and the second half the test.

    Parameters
    ----------
    log_path : path
        Ride to fit.
    compare_path : path, optional
        Ride to test on.
    report_dir : path, optional
        Where to write ``ride_balance.png`` and ``ride_balance.csv`` (test ride:
        t, measured and predicted battery power), atomically.
    assumptions : RideAssumptions
    rate, max_gap, window, polyorder :
        See :func:`ride_signals`.
    domain : {"power", "torque"}
    n_boot, block_s, seed :
        See :func:`fit_balance`.

    Returns
    -------
    RideAnalysis
        ``.report`` is the dict
        ``{"effects": [...], "heldout_error_nominal", "heldout_error_augmented",
        "error_unit"}`` plus ``ratio``, ``nominal_parameters`` (the efficiencies
        of the augmented fit, with plausibility flags), ``all_estimates`` (every
        candidate of the full fit, flagged), ``aliases``, ``torque_method``,
        ``power_source``, ``assumptions``, ``filter``, ``bootstrap``, ``notes``,
        ``figure``.
    """
    sig_fit = ride_signals(log_path, assumptions, rate, max_gap, window, polyorder)
    d_all = balance_design(sig_fit, domain)
    if compare_path is not None:
        sig_test = ride_signals(compare_path, assumptions, rate, max_gap, window, polyorder)
        d_fit, d_test = d_all, balance_design(sig_test, domain)
        fit_label, test_label = Path(log_path).name, Path(compare_path).name
    else:
        sig_test = None
        t_mid = 0.5 * (d_all.t[0] + d_all.t[-1])
        d_fit, d_test = d_all.rows(d_all.t < t_mid), d_all.rows(d_all.t >= t_mid)
        fit_label = f"{Path(log_path).name} (first half)"
        test_label = f"{Path(log_path).name} (second half)"
    cr = cross_ride(d_fit, d_test, n_boot, block_s, seed, fit_label, test_label)
    aug_phys = plausibility(cr.augmented)
    notes = list(sig_fit.notes) + list(d_fit.notes)
    notes.append(f"masses are assumed (m_eq = {assumptions.m_eq:g} kg, total {assumptions.total_mass:g} "
                 f"kg): the power balance fixes only m_eq/η_m, so η_m, η_r, k and P₀ scale with the "
                 f"assumed mass; C_rr (a force per weight) does not")
    if sig_test is not None:
        notes += [f"{test_label}: {n}" for n in sig_test.notes]
    report = {
        "recording": str(log_path),
        "compare": None if compare_path is None else str(compare_path),
        "effects": _effects(cr),
        "heldout_error_nominal": cr.heldout_nominal,
        "heldout_error_augmented": cr.heldout_augmented,
        "error_unit": "W" if domain == "power" else "N·m",
        "error_measure": (f"RMS of measured minus predicted battery power"
                          f"{'' if domain == 'power' else ' divided by ω = v/R'} on {test_label}, "
                          f"parameters fitted on {fit_label}"),
        "ratio": cr.ratio,
        "heldout_error_all_candidates": cr.heldout_full,
        "insample_error_nominal": cr.nominal.rmse,
        "insample_error_augmented": cr.augmented.rmse,
        "nominal_parameters": {k: aug_phys[k] for k in NOMINAL},
        "inertia_only_parameters": plausibility(cr.nominal),
        "all_estimates": plausibility(cr.full),
        "aliases": {k: list(v) for k, v in d_fit.aliases.items()},
        "confounded": {k: list(cr.full.confounded(k)) for k in cr.full.names
                       if cr.full.confounded(k)},
        "bootstrap_correlation_full_fit": {f"{a}~{b}": r for (a, b), r in cr.full.boot_corr.items()
                                           if a < b},
        "domain": domain,
        "torque_method": sig_fit.torque_method,
        "power_source": sig_fit.power_source,
        "assumptions": assumptions.as_dict(),
        "filter": {"rate_hz": rate, "window_s": window, "polyorder": polyorder,
                   "max_gap_s": max_gap},
        "bootstrap": {"n_boot": n_boot, "block_s": block_s, "seed": seed},
        "rows": {"fit": len(d_fit.P), "test": len(d_test.P)},
        "notes": notes,
        "figure": None,
    }
    if report_dir is not None:
        from euc_sim.io import atomic_write
        report_dir = Path(report_dir)
        fig = plot_cross_ride(cr, report_dir / "ride_balance.png", sig_fit, sig_test)
        table = pd.DataFrame({"t": d_test.t, "v": d_test.v, "P_measured": d_test.P,
                              "P_nominal": d_test.predict(cr.nominal.estimate),
                              "P_augmented": d_test.predict(cr.augmented.estimate)})
        atomic_write(report_dir / "ride_balance.csv", lambda p: table.to_csv(p, index=False))
        report["figure"] = str(fig)
    return RideAnalysis(report=report, cross=cr, sig_fit=sig_fit, sig_test=sig_test)
