"""Battery power and speed of a ride log on one grid: the signals every energy fit reads.

The ride's one grid (:func:`~euc_sim.rides.grids.signals.ride_grid`), the wheel speed
corrected by its GPS scale (:func:`speed_scale`; a 6 % optimistic speedometer makes the
mass 12 % low, a·v scaling with its square), every channel filtered alike, battery power
V·I and the climb rate from GPS altitude over 10 s.  The mass, drivetrain, PWM and grade
fits of :mod:`euc_sim.rides.drive` start from :func:`power_signals`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from euc_sim.errors import BadInputFile
from euc_sim.geo import haversine
from euc_sim.model.catalog import G, RHO_AIR
from euc_sim.rides.grids.signals import ride_grid, sg
from euc_sim.rides.source.channels import current_from_phase
from euc_sim.rides.source.gaps import GAP_POLICY, GapPolicy
from euc_sim.rides.source.ride import Ride
from euc_sim.rides.source.systematic import CURRENT_SCALE_SD, GRADE_SHARE

__all__ = ["G", "RHO_AIR", "NO_GPS_SCALE_SD", "RideDataError", "MassSettings", "SpeedScale",
           "PowerSignals", "speed_scale", "track_scale", "power_signals"]

#: Speedometer-scale standard deviation, when no GPS speed measures it (relative).
NO_GPS_SCALE_SD = 0.05
#: Speed above which GPS and wheel speed are compared (both), m/s.
GPS_V_MIN = 4.0


class RideDataError(BadInputFile):
    """A log without what the mass estimate needs; names the file and the column."""


@dataclass(frozen=True)
class MassSettings:
    """How the mass is estimated.

    Attributes
    ----------
    rate, window, max_gap : float
        Grid rate (Hz), Savitzky–Golay window (s) of the filtered signals, longest interval
        bridged (s, the gap policy's ``bridge``).
    v_min : float
        Samples slower than this, m/s, are not fitted.
    max_lag : float
        Largest delay between current and speed searched, s.
    windows : tuple of float
        Energy-balance windows, s (:mod:`euc_sim.rides.drive.energy`); the interval pools them.
    block : float
        Bootstrap block, s.
    scale_method : {"doppler", "mean", "track"}
        The GPS speed scale (:func:`speed_scale`).
    copper_model : {"force", "accel"}
        Without phase current, the copper loss's column: the squared drive force
        (m·a + c₁ + c₃v²)² (iterated) or its proxy a².
    current_scale_sd, grade_share : float
        Priors of :mod:`euc_sim.rides.source.systematic`.
    n_boot, seed : int
        Bootstrap replicates; seed of every random draw.
    """

    rate: float = GAP_POLICY.rate
    window: float = 1.0
    max_gap: float = GAP_POLICY.bridge
    v_min: float = 1.0
    max_lag: float = 1.0
    windows: tuple = (2.0, 4.0, 8.0)
    block: float = 30.0
    n_boot: int = 200
    seed: int = 0
    scale_method: str = "doppler"
    copper_model: str = "force"
    current_scale_sd: float = CURRENT_SCALE_SD
    grade_share: float = GRADE_SHARE


@dataclass(frozen=True)
class SpeedScale:
    """True over logged wheel speed: ``estimate``, its relative ``sd``, ``source`` (``"gps"``, ``"assumed"``, ...)."""

    estimate: float
    sd: float
    source: str


@dataclass(frozen=True)
class PowerSignals:
    """Filtered signals on the grid, one entry per sample.

    Attributes
    ----------
    t, segment : numpy.ndarray
        s; segment label (split at gaps).
    v, a, av : numpy.ndarray
        Corrected speed m/s, acceleration m/s², d/dt(v²/2) W/kg.
    P : numpy.ndarray
        Battery power V·I, W.
    climb : numpy.ndarray or None
        g·ḣ from GPS altitude, W/kg.
    signed : bool
        Whether the log's current is signed (regeneration visible).
    scale : SpeedScale
    extra : dict
        Other filtered channels (``voltage``, ``current``, ``pwm``, ``phase_current``).
    raw : dict
        Unfiltered: ``v`` (corrected, m/s), ``P`` (W), ``h`` (GPS altitude over 10 s, m) and
        ``phase_current`` (A), where present.
    current_from_phase : bool
        The log's :func:`~euc_sim.rides.source.channels.current_from_phase` (then no ``phase_current`` in ``extra``).
    """

    t: np.ndarray
    segment: np.ndarray
    v: np.ndarray
    a: np.ndarray
    av: np.ndarray
    P: np.ndarray
    climb: np.ndarray | None
    signed: bool
    scale: SpeedScale
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)
    raw: Mapping[str, np.ndarray] = field(default_factory=dict)
    current_from_phase: bool = False


def speed_scale(log: Ride, method: str = "doppler") -> SpeedScale:
    """True speed over logged wheel speed, from GPS.

    Doppler: least squares through the origin of GPS speed on wheel speed (both above
    :data:`GPS_V_MIN` m/s); track: :func:`track_scale`.  ``method`` picks the estimate; the sd is 1 %
    with Doppler alone, √(0.01² + (difference/2)²) with both (docs/drivetrain.md).  Without
    GPS speed: 1 ± :data:`NO_GPS_SCALE_SD`, ``source="assumed"``.
    """
    if method not in ("mean", "doppler", "track"):
        raise ValueError(f"method must be 'mean', 'doppler' or 'track', got {method!r}")
    d = log.data
    if "gps_speed" not in d:
        return SpeedScale(1.0, NO_GPS_SCALE_SD, "assumed")
    v, g = d["v"].to_numpy(float), d["gps_speed"].to_numpy(float)
    ok = np.isfinite(g) & (v > GPS_V_MIN) & (g > GPS_V_MIN)
    if ok.sum() < 50:
        return SpeedScale(1.0, NO_GPS_SCALE_SD, "assumed")
    k = float(np.sum(g[ok] * v[ok]) / np.sum(v[ok] ** 2))
    k_track = track_scale(log)
    if k_track is None:
        # GPS speed is good to about 1 % in the mean (Doppler); the scatter of
        # single samples is averaged over thousands of them.
        return SpeedScale(k, 0.01, "gps")
    # the two GPS measurements disagree by more than either's noise: the sd covers both
    sd = float(np.hypot(0.01, 0.5 * (k_track - k)))
    if method == "doppler":
        return SpeedScale(k, sd, "gps")
    if method == "track":
        return SpeedScale(k_track, sd, "gps track")
    return SpeedScale(0.5 * (k + k_track), sd, "gps doppler+track")


def track_scale(log: Ride) -> float | None:
    """GPS track distance (haversine) over the wheel's ∫v dt between successive distinct fixes
    at most :attr:`GapPolicy.gps_pair` s apart, both above :data:`GPS_V_MIN`; None without 50 such pairs.
    """
    d = log.data
    if "latitude" not in d or "longitude" not in d:
        return None
    t, v = d["t"].to_numpy(float), d["v"].to_numpy(float)
    lat, lon = d["latitude"].to_numpy(float), d["longitude"].to_numpy(float)
    idx = np.flatnonzero(np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) + np.abs(lon) > 1e-6))
    if idx.size < 50:
        return None
    idx = idx[np.r_[True, (np.diff(lat[idx]) != 0) | (np.diff(lon[idx]) != 0)]]
    run = np.r_[0.0, np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))]
    a, b = idx[:-1], idx[1:]
    use = (v[a] > GPS_V_MIN) & (v[b] > GPS_V_MIN) & (t[b] - t[a] < GAP_POLICY.gps_pair)
    if use.sum() < 50:
        return None
    dist = haversine(lat[a], lon[a], lat[b], lon[b])
    wheel = run[b] - run[a]
    return float(dist[use].sum() / wheel[use].sum())


def power_signals(log: Ride, settings: MassSettings = MassSettings()) -> PowerSignals:
    """Resample, correct the speed scale and filter every channel alike (kept on ``log``).

    ``RideDataError`` naming file and column: no voltage or current, or a speed never above
    ``settings.v_min``.
    """
    for col in ("voltage", "current"):
        if col not in log.data:
            raise RideDataError(f"{log.path}: column {col!r}: absent or all zero; battery "
                                f"power V·I is needed for the mass and the drivetrain")
    if not (log.data["v"] > settings.v_min).any():
        raise RideDataError(f"{log.path}: column 'speed': never above "
                            f"{settings.v_min * 3.6:.1f} km/h; nothing was ridden")
    return log.derived(("power", settings.rate, settings.max_gap, settings.window,
                        settings.scale_method), lambda: _filtered(log, settings))


def _filtered(log: Ride, settings: MassSettings) -> PowerSignals:
    """:func:`power_signals` of a ride whose columns were checked."""
    frame, _ = ride_grid(log, GapPolicy(bridge=settings.max_gap, rate=settings.rate))
    seg = frame["segment"].to_numpy()
    k = speed_scale(log, method=settings.scale_method)
    f = lambda x, deriv=0: sg(x, seg, settings.rate, settings.window, 2, deriv)   # noqa: E731
    v_raw = frame["v"].to_numpy(float) * k.estimate
    P = frame["voltage"].to_numpy(float) * frame["current"].to_numpy(float)
    climb = None
    raw = {"v": v_raw, "P": P}
    if "gps_alt" in frame and np.isfinite(frame["gps_alt"]).mean() > 0.5:
        # GPS altitude is noisy (metres): its climb rate from a 10 s fit.
        alt = frame["gps_alt"].to_numpy(float)
        climb = G * sg(np.nan_to_num(alt), seg, settings.rate, 10.0, 2, 1)
        climb[~np.isfinite(alt)] = np.nan
        raw["h"] = np.where(np.isfinite(alt), sg(np.nan_to_num(alt), seg, settings.rate, 10.0, 2), np.nan)
    extra = {c: f(frame[c].to_numpy(float)) for c in
             ("voltage", "current", "pwm", "phase_current") if c in frame}
    from_phase = current_from_phase(log)
    if from_phase:
        extra.pop("phase_current")
    elif "phase_current" in frame:
        raw["phase_current"] = frame["phase_current"].to_numpy(float)
    signed = bool((log.data["current"] < -0.5).mean() > 0.005)
    return PowerSignals(t=frame["t"].to_numpy(float), segment=seg, v=f(v_raw),
                        a=f(v_raw, 1), av=f(0.5 * v_raw ** 2, 1), P=f(P), climb=climb,
                        signed=signed, scale=k, extra=extra, raw=raw, current_from_phase=from_phase)
