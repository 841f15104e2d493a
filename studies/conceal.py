"""Hide one known effect in a real EUC World log, consistently across its channels.

A concealed copy is the ride the wheel would have logged had one thing been
different: more mass, more drag, more rolling resistance, an aged battery, a
tyre size set wrong in the app, or a late current channel.  Each effect's record
(:mod:`euc_sim.model.catalog`, its ``conceal`` face) names its mechanism and, for more
power at the wheel, that power.  Every injection is
a pure function of the raw log table (the CSV as the app wrote it, read with
:func:`read_raw`) that returns a new table; the input is never changed, and
nothing is drawn at random.

The physics (the paper's longitudinal balance, eq. 5–6, and the drivetrain of
:mod:`euc_sim.rides.drive.drivetrain`):

- extra wheel power ``ΔP_w = ΔF·v`` with ``ΔF = Δm·(a + g·sinθ)`` (mass, the
  grade from GPS altitude), ``½ρ·ΔC_dA·v²`` (drag) or ``ΔC_rr·m·g`` (rolling);
- battery power ``P = P_w/η`` when motoring, ``P_w·η`` when braking;
- the pack's own sag: ``V = W − k_Q·ΔQ − R·I`` with ``W = V + R·I`` the logged
  EMF, ``ΔQ`` the extra charge drawn and ``R``, ``k_Q`` fitted on the log
  (``V = E₀ − k_Q·Q − R·I``), and ``V·I = P`` solved for the new current;
- phase current ``I_ph = k_ph·F + c`` and duty ``d·V = K_v·v + r_F·F``, their
  constants fitted on the log itself (``F = P/v`` above 2 m/s).

Study: docs/concealed.md.
"""

from __future__ import annotations

from euc_sim.errors import InputError

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.signal import savgol_filter

from euc_sim.rides.drive.drivetrain import charge_drawn
from euc_sim.simulation.effects import RECORDS

__all__ = ["LogConstants", "Kinematics", "MECHANISMS", "concealable", "read_raw", "write_raw", "kinematics",
           "log_constants", "add_wheel_power", "conceal_wheel_power",
           "conceal_resistance", "conceal_tyre_size",
           "conceal_current_delay", "conceal", "electrical_power", "battery_current", "charge_drawn"]

KMH = 1.0 / 3.6
#: Speed above which force is taken as power over speed, m/s.
V_MIN = 2.0
#: Grid step of the smoothing and differentiation, s.
GRID = 0.1
#: Columns every concealment needs (EUC World layout).
REQUIRED = ("datetime", "speed", "voltage", "current")
#: Wheel-speed-derived columns, km/h or km/h/s (scaled by a tyre-size error).
SPEED_COLUMNS = ("speed", "speed_avg", "speed_avg_riding", "speed_max", "acceleration")


@dataclass(frozen=True)
class Kinematics:
    """Per-row kinematics of a raw log.

    Attributes
    ----------
    t : ndarray
        s from the first row.
    v : ndarray
        Wheel speed, m/s (as logged).
    a : ndarray
        Acceleration, m/s² (1 s Savitzky–Golay derivative).
    sin_grade : ndarray
        sinθ of the road from GPS altitude (15 s smoothing), 0 where unknown.
    """

    t: np.ndarray
    v: np.ndarray
    a: np.ndarray
    sin_grade: np.ndarray


@dataclass(frozen=True)
class LogConstants:
    """The log's own battery, phase-current and duty constants.

    Attributes
    ----------
    R_pack : float
        Pack resistance, Ω.
    k_Q : float
        Open-circuit voltage fall per ampere-hour drawn, V/Ah.
    k_phase : float or None
        Phase amperes per newton at the wheel (None without a phase-current column).
    K_v : float or None
        Back-EMF, V per m/s (None without PWM or safety margin).
    r_F : float or None
        Resistive drop, V per N.
    """

    R_pack: float
    k_Q: float
    k_phase: float | None
    K_v: float | None
    r_F: float | None


def read_raw(path) -> pd.DataFrame:
    """The EUC World CSV as written (columns and units of the app)."""
    raw = pd.read_csv(path, dtype={"extra": str, "datetime": str})
    missing = [c for c in REQUIRED if c not in raw.columns]
    if missing:
        raise InputError(f"{path}: column {missing[0]!r} missing (not an EUC World log)")
    return raw


def write_raw(raw: pd.DataFrame, path) -> Path:
    """Write a (concealed) raw table as CSV; refuses to overwrite an existing file."""
    path = Path(path)
    if path.exists():
        raise FileExistsError(f"{path}: exists; a concealed log never overwrites a file")
    raw.to_csv(path, index=False)
    return path


def _times(raw: pd.DataFrame) -> np.ndarray:
    ts = pd.to_datetime(raw["datetime"], format="ISO8601", utc=True)
    t = (ts - ts.iloc[0]).dt.total_seconds().to_numpy(float)
    return np.maximum.accumulate(t)


def _on_grid(t: np.ndarray, x: np.ndarray):
    """Uniform grid and ``x`` interpolated on it (rows sharing a time stamp averaged)."""
    ok = np.isfinite(x)
    tu, inv = np.unique(t[ok], return_inverse=True)
    xu = np.bincount(inv, weights=x[ok]) / np.bincount(inv)
    grid = np.arange(tu[0], tu[-1] + GRID / 2, GRID)
    return grid, np.interp(grid, tu, xu)


def _smooth_derivative(t: np.ndarray, x: np.ndarray, window_s: float) -> np.ndarray:
    """d x / d t at each row: Savitzky–Golay on a uniform grid, read back at ``t``."""
    if np.isfinite(x).sum() < 3:
        return np.zeros_like(t)
    grid, xg = _on_grid(t, x)
    n = int(window_s / GRID) | 1
    if len(grid) <= n:
        return np.zeros_like(t)
    return np.interp(t, grid, savgol_filter(xg, n, 1 if window_s > 5 else 2, deriv=1, delta=GRID))


def kinematics(raw: pd.DataFrame) -> Kinematics:
    """Speed, acceleration and road grade of each row of a raw log."""
    t = _times(raw)
    v = raw["speed"].to_numpy(float) * KMH
    a = _smooth_derivative(t, np.nan_to_num(v), 1.0)
    sin_grade = np.zeros_like(t)
    if "gps_alt" in raw and raw["gps_alt"].notna().sum() > 10:
        hdot = _smooth_derivative(t, raw["gps_alt"].to_numpy(float), 15.0)
        moving = v > V_MIN
        sin_grade[moving] = np.clip(hdot[moving] / v[moving], -0.25, 0.25)
    return Kinematics(t=t, v=v, a=a, sin_grade=sin_grade)


def _duty(raw: pd.DataFrame) -> np.ndarray | None:
    """Duty 0–1 from ``pwm`` or ``100 − safety_margin`` (None where neither is logged)."""
    if "pwm" in raw and raw["pwm"].notna().any():
        return raw["pwm"].to_numpy(float) / 100.0
    if "safety_margin" in raw and raw["safety_margin"].notna().any():
        return 1.0 - raw["safety_margin"].to_numpy(float) / 100.0
    return None


def _fit(X: np.ndarray, y: np.ndarray) -> np.ndarray | None:
    ok = np.all(np.isfinite(X), axis=1) & np.isfinite(y)
    if ok.sum() < X.shape[1] + 10:
        return None
    return np.linalg.lstsq(X[ok], y[ok], rcond=None)[0]


def log_constants(raw: pd.DataFrame, kin: Kinematics) -> LogConstants:
    """Fit the pack resistance, the phase-current gain and the duty model on the log itself."""
    V, I = raw["voltage"].to_numpy(float), raw["current"].to_numpy(float)
    Q = charge_drawn(kin.t, I)
    bat = _fit(np.column_stack([np.ones_like(V), -Q, -I]), V)
    R = float(max(bat[2], 0.0)) if bat is not None else 0.0
    k_Q = float(max(bat[1], 0.0)) if bat is not None else 0.0
    moving = kin.v > V_MIN
    F = np.where(moving, V * I / np.where(moving, kin.v, 1.0), np.nan)
    k_ph = None
    if "current_phase" in raw and raw["current_phase"].notna().sum() > 50:
        c = _fit(np.column_stack([F, np.ones_like(F)]), raw["current_phase"].to_numpy(float))
        k_ph = None if c is None else float(c[0])
    d = _duty(raw)
    K_v = r_F = None
    if d is not None:
        c = _fit(np.column_stack([np.where(moving, kin.v, np.nan), F]), d * V)
        if c is not None:
            K_v, r_F = float(c[0]), float(c[1])
    return LogConstants(R_pack=R, k_Q=k_Q, k_phase=k_ph, K_v=K_v, r_F=r_F)


def electrical_power(P_wheel: np.ndarray, eta: float) -> np.ndarray:
    """Battery power of a wheel power, W: ``P_w/η`` motoring, ``P_w·η`` braking."""
    return np.where(P_wheel > 0, P_wheel / eta, P_wheel * eta)


def _wheel_power(P_el: np.ndarray, eta: float) -> np.ndarray:
    """Inverse of :func:`electrical_power`."""
    return np.where(P_el > 0, P_el * eta, P_el / eta)


def battery_current(W: np.ndarray, R: float, P: np.ndarray) -> np.ndarray:
    """Current I with ``(W − R·I)·I = P`` (the smaller root), A.

    Parameters
    ----------
    W : ndarray
        EMF behind the resistance, V.
    R : float
        Resistance, Ω.
    P : ndarray
        Terminal power, W.
    """
    if R <= 0:
        return P / W
    disc = np.maximum(W * W - 4.0 * R * P, 0.0)
    return 2.0 * P / (W + np.sqrt(disc))


def _set_battery(raw: pd.DataFrame, out: pd.DataFrame, consts: LogConstants, R_total: float,
                 P_new: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Write voltage, current and power for a new terminal power; returns the new voltage.

    The EMF behind the pack's resistance is the logged one, ``V + R·I``, less
    ``k_Q`` times the extra charge drawn (repeated: the extra charge depends
    on the new current; five passes converge).
    """
    V, I = raw["voltage"].to_numpy(float), raw["current"].to_numpy(float)
    W = V + consts.R_pack * I
    ok = np.isfinite(P_new)
    I_new = I
    for _ in range(5):
        Wq = W - consts.k_Q * charge_drawn(t, np.where(ok, I_new - I, 0.0))
        I_new = np.where(ok, battery_current(Wq, R_total, np.nan_to_num(P_new)), I)
    V_new = np.where(ok, Wq - R_total * I_new, V)
    out["voltage"], out["current"] = V_new, I_new
    if "power" in raw:
        out["power"] = raw["power"].to_numpy(float) + np.nan_to_num(V_new * I_new - V * I)
    return V_new


def _set_duty(raw: pd.DataFrame, out: pd.DataFrame, V_new: np.ndarray, dF: np.ndarray,
              r_F: float | None) -> None:
    """Duty with the motor volts ``d·V + r_F·ΔF`` at the new battery voltage."""
    d = _duty(raw)
    if d is None:
        return
    V = raw["voltage"].to_numpy(float)
    d_new = np.clip((d * V + (r_F or 0.0) * dF) / V_new, 0.0, 1.0)
    if "pwm" in raw and raw["pwm"].notna().any():
        out["pwm"] = np.where(np.isfinite(d), d_new * 100.0, raw["pwm"])
    else:
        out["safety_margin"] = np.where(np.isfinite(d), 100.0 - d_new * 100.0, raw["safety_margin"])


def add_wheel_power(raw: pd.DataFrame, dP_wheel: np.ndarray, eta: float,
                    consts: LogConstants, kin: Kinematics) -> pd.DataFrame:
    """A copy of ``raw`` whose wheel needed ``dP_wheel`` more power, W, at each row.

    Battery power changes through ``η`` (:func:`electrical_power`), voltage and
    current through the pack's own sag, phase current and duty through the
    log's constants (``ΔF = ΔP_w/v``).
    """
    out = raw.copy()
    P_el = raw["voltage"].to_numpy(float) * raw["current"].to_numpy(float)
    P_new = electrical_power(_wheel_power(P_el, eta) + dP_wheel, eta)
    V_new = _set_battery(raw, out, consts, consts.R_pack, P_new, kin.t)
    moving = kin.v > V_MIN
    dF = np.where(moving, dP_wheel / np.where(moving, kin.v, 1.0), 0.0)
    if consts.k_phase is not None and "current_phase" in raw:
        out["current_phase"] = raw["current_phase"] + consts.k_phase * dF
    _set_duty(raw, out, V_new, dF, consts.r_F)
    return out


def conceal_wheel_power(raw: pd.DataFrame, effect: str, size: float, eta: float = 0.85, **kw) -> pd.DataFrame:
    """``size`` more of ``effect``, whose record's ``conceal.wheel_power(kin, size, **kw)`` is the
    extra wheel power, W (:func:`add_wheel_power`)."""
    kin = kinematics(raw)
    dP = RECORDS.get(effect).conceal.wheel_power(kin, size, **kw)
    return add_wheel_power(raw, dP, eta, log_constants(raw, kin), kin)


def conceal_resistance(raw: pd.DataFrame, dR: float) -> pd.DataFrame:
    """An aged pack, ``dR`` Ω more, drawing the same power: V falls, I rises so V·I stays."""
    kin = kinematics(raw)
    consts = log_constants(raw, kin)
    out = raw.copy()
    P = raw["voltage"].to_numpy(float) * raw["current"].to_numpy(float)
    V_new = _set_battery(raw, out, consts, consts.R_pack + dR, P, kin.t)
    _set_duty(raw, out, V_new, np.zeros_like(P), consts.r_F)
    return out


def conceal_tyre_size(raw: pd.DataFrame, factor: float) -> pd.DataFrame:
    """Tyre size set wrong in the app: wheel speed and distance read ``factor`` × true; GPS not."""
    out = raw.copy()
    for c in SPEED_COLUMNS:
        if c in raw:
            out[c] = raw[c] * factor
    if "distance" in raw:
        out["distance"] = raw["distance"] * factor
    if "distance_total" in raw and raw["distance_total"].notna().any():
        d0 = raw["distance_total"].dropna().iloc[0]
        out["distance_total"] = d0 + (raw["distance_total"] - d0) * factor
    return out


def conceal_current_delay(raw: pd.DataFrame, delay: float,
                          columns: tuple[str, ...] = ("current", "current_phase", "power")
                          ) -> pd.DataFrame:
    """The current sensor's channels logged ``delay`` s late (interpolated; the first held)."""
    t = _times(raw)
    out = raw.copy()
    for c in columns:
        if c not in raw or raw[c].notna().sum() < 2:
            continue
        x = raw[c].to_numpy(float)
        ok = np.isfinite(x)
        tu, idx = np.unique(t[ok], return_index=True)
        out[c] = np.where(ok, np.interp(t - delay, tu, x[ok][idx]), x)
    return out


#: A record's conceal mechanism -> the injection ``f(raw, effect, size, **kw)``.
MECHANISMS = {
    "wheel_power": conceal_wheel_power,
    "pack_resistance": lambda raw, effect, size: conceal_resistance(raw, size),
    "speed_scale": lambda raw, effect, size: conceal_tyre_size(raw, size),
    "channel_delay": lambda raw, effect, size, **kw: conceal_current_delay(raw, size, **kw),
}


def concealable() -> dict[str, str]:
    """The effects a log can conceal (records with a conceal face) and the unit of their size."""
    return {e.name: e.conceal.unit for e in RECORDS.having("conceal")}


def conceal(raw: pd.DataFrame, effect: str, size: float, **kw) -> pd.DataFrame:
    """Hide ``effect`` of ``size`` in ``raw`` (:func:`concealable`); ``"null"`` returns a copy."""
    if effect == "null":
        return raw.copy()
    if effect not in RECORDS or RECORDS.get(effect).conceal is None:
        raise InputError(f"effect {effect!r}: not one of null, {', '.join(concealable())}")
    return MECHANISMS[RECORDS.get(effect).conceal.mechanism](raw, effect, size, **kw)
