"""Maneuvers: the rider's planned speed v_ref(t), and the prescribed slalom of ``lateral_dynamics``."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from euc_sim.simulation.errors import SimulationError


MANEUVERS = ("constant_speed", "acceleration", "deceleration", "stop_and_go", "profile")
#: Period of the lateral_dynamics slalom, s, and the speed floor of its yaw rate, m/s.
LATERAL_PERIOD = 6.0
LATERAL_MIN_SPEED = 1.0
#: Speed from which the slalom reaches its full tilt, m/s.
LATERAL_FULL_TILT_SPEED = 2.0


# --- maneuvers ---------------------------------------------------------------------
def _ramp(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cosine ramp s(u) = (1 − cos πu)/2 on [0, 1] and its derivative."""
    uc = np.clip(u, 0.0, 1.0)
    inside = (u > 0.0) & (u < 1.0)
    return 0.5 * (1.0 - np.cos(np.pi * uc)), np.where(inside, 0.5 * np.pi * np.sin(np.pi * uc), 0.0)


def _add_ramp(v: np.ndarray, a: np.ndarray, u: np.ndarray, dv: float, dur: float) -> None:
    """``v += dv·s(u)`` and ``a += dv·s'(u)/dur`` in place, :func:`_ramp` evaluated inside (0, 1) only."""
    inside = (u > 0.0) & (u < 1.0)
    v += dv * (u >= 1.0)
    if inside.any():
        s, ds = _ramp(u[inside])
        v[inside] += dv * s
        a[inside] += dv * ds / dur


@dataclass(frozen=True)
class Maneuver:
    """A planned speed profile v_ref(t).

    Attributes
    ----------
    name : str
        One of :data:`MANEUVERS`.
    v0 : float
        Speed at t = 0, m/s.
    ramps : tuple of (start, duration, target)
        Cosine speed changes: start s, duration s, target speed m/s.
    table : tuple of (t, v) tuples, optional
        A tabulated profile (``profile``), PCHIP-interpolated, held beyond its ends.
    options : tuple of (name, value)
        The :func:`make_maneuver` options that rebuild it.
    """

    name: str
    v0: float = 0.0
    ramps: tuple = ()
    table: tuple | None = field(default=None)
    options: tuple = ()

    def reference(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Planned speed (m/s) and acceleration (m/s²) at times t (s)."""
        t = np.asarray(t, dtype=float)
        if self.table is not None:
            from scipy.interpolate import PchipInterpolator

            tt, vv = (np.asarray(c, dtype=float) for c in self.table)
            if len(tt) == 1:
                return np.full_like(t, vv[0]), np.zeros_like(t)
            f = PchipInterpolator(tt, vv, extrapolate=False)
            tc = np.clip(t, tt[0], tt[-1])
            a = f.derivative()(tc)
            a = np.where((t < tt[0]) | (t > tt[-1]), 0.0, a)
            return f(tc), a
        v = np.full_like(t, self.v0)
        a = np.zeros_like(t)
        prev = self.v0
        for start, dur, target in self.ramps:
            _add_ramp(v, a, (t - start) / dur, target - prev, dur)
            prev = target
        return v, a

    def as_dict(self) -> dict:
        """JSON-ready description."""
        d = {"name": self.name, "v0": self.v0, "ramps": [list(r) for r in self.ramps],
             "options": dict(self.options)}
        if self.table is not None:
            d["table"] = {"t": list(self.table[0]), "v": list(self.table[1])}
        return d


#: What a maneuver option may be: speeds in m/s (an EUC tops out near 30), times in s
#: (an hour), up to 100 stop-and-go cycles.
OPTION_RANGES = {"v": (-30.0, 30.0), "v0": (-30.0, 30.0), "v1": (-30.0, 30.0), "start": (0.0, 3600.0),
                 "ramp": (0.0, 3600.0), "hold": (0.0, 3600.0), "cycles": (1, 100)}


def make_maneuver(name: str, **options) -> Maneuver:
    """A built-in maneuver shaped like the paper's recordings (speeds in m/s, times in s).

    ``constant_speed`` (option v), ``acceleration`` and ``deceleration`` (v0, v1, start,
    ramp) or ``stop_and_go`` (v, start, ramp, hold, cycles); ``options`` override the
    defaults.  ``SimulationError`` listing the valid names or options.
    """
    defaults = {
        "constant_speed": {"v": 3.0},
        "acceleration": {"v0": 1.0, "v1": 4.0, "start": 3.0, "ramp": 4.0},
        "deceleration": {"v0": 4.0, "v1": 0.5, "start": 3.0, "ramp": 4.0},
        "stop_and_go": {"v": 2.5, "start": 1.0, "ramp": 3.0, "hold": 2.0, "cycles": 3},
    }
    if name not in defaults:
        valid = ", ".join(MANEUVERS)
        raise SimulationError(f"unknown maneuver {name!r}; valid maneuvers: {valid} "
                              "(profile needs a speed-profile CSV)")
    unknown = sorted(set(options) - set(defaults[name]))
    if unknown:
        raise SimulationError(f"maneuver {name!r} has no option {unknown[0]!r}; "
                              f"options: {', '.join(defaults[name])}")
    o = {**defaults[name], **options}
    for key, val in o.items():
        if isinstance(val, bool) or not (isinstance(val, (int, float)) and math.isfinite(val)):
            raise SimulationError(f"maneuver option {key!r} must be a finite number, got {val!r}")
        lo, hi = OPTION_RANGES[key]
        if not lo <= val <= hi:
            raise SimulationError(f"maneuver option {key!r} must lie in [{lo:g}, {hi:g}], got {val:g}")
    opts = tuple(sorted(options.items()))
    if name == "constant_speed":
        return Maneuver(name, float(o["v"]), options=opts)
    if name in ("acceleration", "deceleration"):
        if o["ramp"] <= 0:
            raise SimulationError(f"maneuver option 'ramp' must be positive, got {o['ramp']!r}")
        return Maneuver(name, float(o["v0"]), ((float(o["start"]), float(o["ramp"]), float(o["v1"])),),
                        options=opts)
    if o["ramp"] <= 0 or o["hold"] < 0 or int(o["cycles"]) < 1:
        raise SimulationError(f"stop_and_go needs ramp > 0, hold >= 0, cycles >= 1, got {o!r}")
    ramps, t = [], float(o["start"])
    for _ in range(int(o["cycles"])):
        ramps.append((t, float(o["ramp"]), float(o["v"])))
        t += o["ramp"] + o["hold"]
        ramps.append((t, float(o["ramp"]), 0.0))
        t += o["ramp"] + o["hold"]
    return Maneuver(name, 0.0, tuple(ramps), options=opts)


def load_speed_profile(path: str | Path) -> Maneuver:
    """A ``profile`` maneuver from a CSV with columns ``t`` (s, strictly increasing) and ``v``
    (m/s); ``SimulationError`` naming what is missing or malformed.
    """
    path = Path(path)
    if not path.is_file():
        raise SimulationError(f"speed profile {path}: no such file")
    try:
        df = pd.read_csv(path)
    except Exception as exc:  # pandas raises several types for bad CSV
        raise SimulationError(f"speed profile {path}: cannot read CSV ({type(exc).__name__}: "
                              f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
    df.columns = [str(c).strip() for c in df.columns]
    missing = [c for c in ("t", "v") if c not in df.columns]
    if missing:
        raise SimulationError(f"speed profile {path}: expected columns t, v; missing {', '.join(missing)} "
                              f"(found {', '.join(map(str, df.columns)) or 'none'})")
    try:
        t = pd.to_numeric(df["t"]).to_numpy(dtype=float)
        v = pd.to_numeric(df["v"]).to_numpy(dtype=float)
    except (ValueError, TypeError):
        raise SimulationError(f"speed profile {path}: columns t and v must be numbers") from None
    if len(t) < 1:
        raise SimulationError(f"speed profile {path}: expected at least one row, got none")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise SimulationError(f"speed profile {path}: t and v must be finite numbers")
    if np.any(np.diff(t) <= 0):
        i = int(np.nonzero(np.diff(t) <= 0)[0][0])
        raise SimulationError(f"speed profile {path}: t must be strictly increasing, got "
                              f"{t[i]:g} then {t[i + 1]:g} at rows {i + 1}-{i + 2}")
    return Maneuver("profile", float(v[0]), (), (tuple(t.tolist()), tuple(v.tolist())))


def as_maneuver(maneuver) -> Maneuver:
    if isinstance(maneuver, Maneuver):
        return maneuver
    if isinstance(maneuver, str):
        if maneuver == "profile":
            raise SimulationError("maneuver 'profile' needs a speed-profile CSV: "
                                  "pass load_speed_profile(path)")
        return make_maneuver(maneuver)
    raise SimulationError(f"maneuver must be a name or a Maneuver, got {type(maneuver).__name__}")


@dataclass(frozen=True)
class LateralMotion:
    """Prescribed tilt and yaw over t: ``theta`` (rad), ``theta_d`` (rad/s), ``psi`` (rad), ``psi_d`` (rad/s), ``psi_dd`` (rad/s²)."""

    theta: np.ndarray
    theta_d: np.ndarray
    psi: np.ndarray
    psi_d: np.ndarray
    psi_dd: np.ndarray


def lateral_profile(peak_tilt: float, t, v_ref) -> LateralMotion:
    """Slalom of the ``lateral_dynamics`` effect over times ``t``, s, at planned speed ``v_ref``, m/s.

    ϑ ∝ −sin(2π t / :data:`LATERAL_PERIOD`) · min(1, |v_ref| / :data:`LATERAL_FULL_TILT_SPEED`),
    peak ``peak_tilt``, rad; the yaw rate of a coordinated turn, ψ̇ = g tan(−ϑ) /
    max(|v_ref|, :data:`LATERAL_MIN_SPEED`) (leaning left, ϑ < 0, while turning left);
    rates by central differences.
    """
    t = np.asarray(t, dtype=float)
    speed = np.abs(np.asarray(v_ref, dtype=float))
    shape = np.sin(2.0 * np.pi * t / LATERAL_PERIOD) * np.minimum(1.0, speed / LATERAL_FULL_TILT_SPEED)
    peak = float(np.max(np.abs(shape))) if t.size else 0.0
    lean = peak_tilt * shape / peak if peak > 0 else np.zeros_like(t)   # into the turn
    theta = -lean                          # CONTRACT's ϑ, positive to the right (eq. 2)
    psi_d = 9.81 * np.tan(lean) / np.maximum(speed, LATERAL_MIN_SPEED)
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (psi_d[1:] + psi_d[:-1]) * np.diff(t))]) if t.size else t
    rate = (lambda y: np.gradient(y, t)) if t.size > 1 else np.zeros_like
    return LateralMotion(theta, rate(theta), psi, psi_d, rate(psi_d))
