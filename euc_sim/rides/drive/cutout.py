"""The wheel's speed limit and the speed at which its motor runs out of voltage (the cut-out).

The cut-out is the lowest speed reading ``v`` where the fitted duty reaches 1 (:func:`limit_speed`);
the envelope (:func:`envelope`) uses the same model.  With ground speed ``s·v``::

    F     = m_eq·a + m·g·sin(atan(grade)) + c₁ + c₃·(s·v)²     road, slope and inertia, N
    P     = F·s·v + P₀ + copper loss                          battery power, W
    V_ocv = α + β·charge                                      the pack's open-circuit voltage, V
    V_t   = (V_ocv + sqrt(V_ocv² − 4·R_int·P)) / 2            terminal voltage: V_t·(V_ocv − V_t)/R_int = P
    d     = (e(v) + r_F·P/v) / V_t + c_dt                      the fitted duty model, e the back-EMF

Where ``V_ocv² < 4·R_int·P`` the duty is taken as above 1; below 2 m/s (the fit's range) it is NaN.
See docs/cutout.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from euc_sim.rides.drive.drivetrain import _pwm_rows, fit_pwm, predict_pwm
from euc_sim.rides.drive.pwm import back_emf
from euc_sim.stats import rms

__all__ = ["Limits", "ride_limits", "OcvLine", "ocv_line", "Condition", "CONDITIONS", "DutyModel",
           "duty_model", "duty", "limit_speed", "full_duty_accel", "Curve",
           "Cutout", "cutout_curves", "ChargeEnvelope", "Envelope", "envelope", "danger_sentence",
           "headroom_words", "heldout_pwm_rmse", "CHARGE_GRID", "CELL_FULL", "CELL_EMPTY"]

G = 9.81
#: Charge levels the curves are given at, %.
CHARGE_GRID = np.linspace(0.0, 100.0, 41)
#: Open-circuit volts per Li-ion cell at 100 % and at 0 % of a wheel's gauge (the line used
#: where the log's own battery reading cannot give it).
CELL_FULL, CELL_EMPTY = 4.2, 3.3
#: The ride's battery reading must span this many points for its own voltage line, %.
MIN_CHARGE_SPAN = 15.0
#: Speeds searched for the cut-out, m/s: the duty model is fitted above 2 m/s.
SPEED_RANGE = (2.0, 60.0)


@dataclass(frozen=True)
class Limits:
    """The ride JSON's ``summary.limits``.

    Attributes
    ----------
    speed_limit_mps : float or None
        The wheel's speed limit, m/s of its own speed reading.
    source : {"log", "spec"} or None
        The log's speed-limit (tilt-back) column, or the maker's top speed.
    pwm_alarm_pct : float or None
        The PWM alarm threshold, %.
    why : str or None
        What is not known, and why.
    """

    speed_limit_mps: float | None
    source: str | None
    pwm_alarm_pct: float | None
    why: str | None = None

    def words(self) -> str:
        """The limit as a rider reads it: "35 km/h (the tilt-back speed set in the wheel, from the log)"."""
        if self.speed_limit_mps is None:
            return "not known"
        src = ("the tilt-back speed set in the wheel, from the log" if self.source == "log" else
               "the maker's top speed, from the spec: the log has no speed-limit setting")
        return f"{self.speed_limit_mps * 3.6:.0f} km/h ({src})"


def ride_limits(log_limit_mps: float | None, spec_top_mps: float | None) -> Limits:
    """The log's speed limit where it has one, else the spec's top speed; no PWM alarm threshold
    (the logs carry the alarm flags, not their thresholds).

    Parameters
    ----------
    log_limit_mps : float or None
        The log's speed-limit column (EUC World ``speed_limit``), m/s.
    spec_top_mps : float or None
        The specification's top speed, m/s.
    """
    ok = [x is not None and math.isfinite(x) and x > 0 for x in (log_limit_mps, spec_top_mps)]
    speed, source = ((log_limit_mps, "log") if ok[0] else (spec_top_mps, "spec") if ok[1] else (None, None))
    why = ["no speed-limit column in the log and no top speed in the wheel's spec (--wheel)"] if speed is None else []
    why.append("no PWM alarm setting: the logs carry the alarm flags, not their thresholds")
    return Limits(None if speed is None else float(speed), source, None, "; ".join(why))


@dataclass(frozen=True)
class OcvLine:
    """The pack's open-circuit voltage against its charge, ``V = α + β·charge``.

    Attributes
    ----------
    alpha : float
        V at 0 %.
    beta : float
        V per %.
    source : str
        How it was found.
    charge_range : tuple of float or None
        The lowest and highest charge the ride logged, %.
    """

    alpha: float
    beta: float
    source: str
    charge_range: tuple[float, float] | None = None

    def __call__(self, charge):
        return self.alpha + self.beta * np.asarray(charge, float)


def ocv_line(voltage: np.ndarray, current: np.ndarray | None, charge: np.ndarray | None,
             R_int: float, spec_voltage: float | None = None) -> OcvLine | None:
    """The open-circuit voltage line from the log's own battery reading, or from the cells.

    ``V + R_int·I`` against the logged charge, fitted by least squares where the ride's
    reading spans :data:`MIN_CHARGE_SPAN` points or more and rises with charge; else the
    cells' line (:data:`CELL_EMPTY` to :data:`CELL_FULL` V per cell), the cells counted
    from the spec's full voltage or from the log's voltage at its charge.

    Parameters
    ----------
    voltage, current : numpy.ndarray
        Battery voltage, V, and current, A (None: no sag taken out).
    charge : numpy.ndarray or None
        The log's battery reading, %.
    R_int : float
        Internal resistance, Ω.
    spec_voltage : float, optional
        The pack's full-charge voltage, V.

    Returns
    -------
    OcvLine or None
        None when neither the log's charge nor the spec's voltage is known.
    """
    V = np.asarray(voltage, float)
    ocv = V + max(R_int, 0.0) * (np.nan_to_num(np.asarray(current, float)) if current is not None else 0.0)
    q = np.full(V.shape, np.nan) if charge is None else np.asarray(charge, float)
    ok = np.isfinite(ocv) & np.isfinite(q) & (q > 0) & (q <= 100) & (ocv > 0)
    span = (float(q[ok].min()), float(q[ok].max())) if ok.sum() > 10 else None
    if span is not None and span[1] - span[0] >= MIN_CHARGE_SPAN:
        beta, alpha = np.polyfit(q[ok], ocv[ok], 1)
        cells = (alpha + 100.0 * beta) / CELL_FULL
        if beta > 0 and 0.3 < beta * 100.0 / cells < 1.5:          # 0.3–1.5 V per cell from 0 to 100 %
            return OcvLine(float(alpha), float(beta), "the log's voltage against its battery reading", span)
    if spec_voltage:
        n = max(1, round(spec_voltage / CELL_FULL))
        src = "the spec's voltage"
    elif span is not None:
        n = max(1, round(float(np.median(ocv[ok] / (CELL_EMPTY + (CELL_FULL - CELL_EMPTY) * q[ok] / 100.0)))))
        src = "the log's voltage at its battery reading"
    else:
        return None
    return OcvLine(n * CELL_EMPTY, n * (CELL_FULL - CELL_EMPTY) / 100.0,
                   f"{n} cells at {CELL_EMPTY}–{CELL_FULL} V ({src})", span)


@dataclass(frozen=True)
class Condition:
    """A way of riding: steady, accelerating or climbing.

    Attributes
    ----------
    name : str
        The JSON's ``condition``.
    words : str
        As the danger sentence says it.
    accel : float
        m/s².
    grade : float
        Rise over run (0.1 = 10 %).
    """

    name: str
    words: str
    accel: float = 0.0
    grade: float = 0.0


CONDITIONS = (Condition("level", "riding steadily on the level"),
              Condition("accelerating_1mps2", "accelerating at 1 m/s²", accel=1.0),
              Condition("climbing_10pct", "climbing a 10 % slope", grade=0.10))


@dataclass(frozen=True)
class DutyModel:
    """What the duty needs, all fitted on the ride.

    Attributes
    ----------
    pwm : dict
        The duty model's coefficients (:func:`euc_sim.rides.drive.drivetrain.fit_pwm`:
        ``K_v`` V per m/s of the speed reading, ``r_F`` V/N, optional ``dead_time``,
        ``flux_weakening`` with ``v_fw``).
    R_int : float
        The battery's internal resistance, Ω.
    ocv : OcvLine
    m_eq : float
        The mass the accelerations move (rotating inertia included), kg.
    mass : float
        The mass a slope lifts, kg.
    c1 : float
        Rolling resistance and losses linear in speed, N.
    c3 : float
        Drag and losses with v³, kg/m.
    p0 : float
        Constant drain, W.
    copper : float
        The copper loss's coefficient (its unit follows ``copper_column``).
    copper_column : {"phase_current", "force", "accel"}
    scale : float
        Ground speed over the wheel's speed reading.
    """

    pwm: dict
    R_int: float
    ocv: OcvLine
    m_eq: float
    mass: float
    c1: float = 0.0
    c3: float = 0.0
    p0: float = 0.0
    copper: float = 0.0
    copper_column: str = "accel"
    scale: float = 1.0


def _power(m: DutyModel, v: np.ndarray, accel, grade) -> np.ndarray:
    """Battery power, W, riding at reading ``v`` (m/s), accelerating at ``accel`` (m/s²) up ``grade``."""
    vg = m.scale * v
    F = m.m_eq * accel + m.mass * G * np.sin(np.arctan(grade)) + m.c1 + m.c3 * vg ** 2
    basis = {"phase_current": F * m.scale / m.pwm["K_v"], "force": F}.get(m.copper_column, accel)
    return F * vg + m.p0 + m.copper * basis ** 2


def duty(m: DutyModel, v, volts: float, accel=0.0, grade=0.0) -> np.ndarray:
    """The duty, 1 = 100 %, riding at reading ``v`` (m/s) on a pack of open-circuit ``volts`` (V),
    accelerating at ``accel`` (m/s²) up ``grade`` (rise over run).

    The model of the module docstring: ``inf`` where the battery cannot give ``P``; NaN below
    :data:`SPEED_RANGE`'s slowest speed.
    """
    v = np.asarray(v, float)
    P = _power(m, v, accel, grade)
    disc = volts * volts - 4.0 * max(m.R_int, 0.0) * P
    Vt = 0.5 * (volts + np.sqrt(np.maximum(disc, 0.0)))
    with np.errstate(divide="ignore", invalid="ignore"):
        d = (back_emf(m.pwm, v) + m.pwm["r_F"] * P / v) / Vt + m.pwm.get("dead_time", 0.0) * np.sign(P)
    return np.where(v < SPEED_RANGE[0], np.nan, np.where(disc >= 0.0, d, np.inf))


def limit_speed(m: DutyModel, volts: float, c: Condition, fraction: float = 1.0, n: int = 233) -> float:
    """The lowest speed reading, m/s, at which the duty reaches ``fraction`` (1: the cut-out) on a pack
    of open-circuit ``volts`` (V) in condition ``c``: the first of ``n`` speeds in :data:`SPEED_RANGE`
    past it, then :func:`scipy.optimize.brentq`.  0 when reached at the slowest speed; NaN when not
    before the fastest.
    """
    from scipy.optimize import brentq

    grid = np.linspace(*SPEED_RANGE, n)
    over = duty(m, grid, volts, c.accel, c.grade) >= fraction
    if over[0]:
        return 0.0
    if not over.any():
        return float("nan")
    k = int(np.argmax(over))
    f = lambda v: min(float(duty(m, v, volts, c.accel, c.grade)), 10.0) - fraction     # noqa: E731
    return float(brentq(f, grid[k - 1], grid[k], xtol=1e-4))


def full_duty_accel(m: DutyModel, v, volts: float, iterations: int = 60) -> np.ndarray:
    """The acceleration, m/s², at which the duty reaches 100 % at speed reading ``v`` (m/s) on the level:
    what the voltage leaves for speeding up (NaN where the duty is 100 % already at a steady speed).

    The duty rises with the acceleration (more force, more power, more sag), so it is found by
    bisection between 0 and the acceleration the back-EMF alone would leave without sag or losses.
    """
    v = np.asarray(v, float)
    vs = np.maximum(v, SPEED_RANGE[0])                    # below it the duty is NaN: so is the answer
    keep = 1.0 - m.pwm.get("dead_time", 0.0)
    hi = np.maximum((keep * volts - back_emf(m.pwm, vs)) / m.pwm["r_F"] / m.scale
                    + (abs(m.p0) / vs + abs(m.c1)) / m.scale, 0.0) / m.m_eq
    lo = np.zeros_like(vs)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        over = duty(m, vs, volts, mid) >= 1.0
        lo, hi = np.where(over, lo, mid), np.where(over, mid, hi)
    return np.where(duty(m, v, volts) < 1.0, lo, np.nan)


@dataclass(frozen=True)
class Curve:
    """One condition's cut-out speed against charge (NaN: beyond the speeds searched)."""

    condition: Condition
    charge_pct: np.ndarray
    speed_mps: np.ndarray

    def below(self, limit: float) -> float | None:
        """The charge, %, under which the cut-out speed is below ``limit`` (m/s); None when it never is.

        Found by linear interpolation between the grid's levels; 100 when it is below at full charge.
        """
        s = np.where(np.isnan(self.speed_mps), np.inf, self.speed_mps)
        under = s < limit
        if not under.any():
            return None
        k = int(np.flatnonzero(under)[-1])
        if k == s.size - 1:
            return float(self.charge_pct[-1])
        s0, s1 = s[k], s[k + 1]
        if not np.isfinite(s1):
            return float(self.charge_pct[k + 1])
        w = (limit - s0) / (s1 - s0)
        return float(self.charge_pct[k] + w * (self.charge_pct[k + 1] - self.charge_pct[k]))


@dataclass(frozen=True)
class Cutout:
    """The ride JSON's ``cutout``.

    Attributes
    ----------
    curves : tuple of Curve
    heldout_pwm_rmse_pct : float or None
        The duty model's error, percentage points, on the ride's second half when fitted on its first.
    danger : str or None
        :func:`danger_sentence`.
    ocv_source : str or None
        How the charge gives the voltage.
    why : str or None
        Why there are no curves.
    """

    curves: tuple = ()
    heldout_pwm_rmse_pct: float | None = None
    danger: str | None = None
    ocv_source: str | None = None
    charge_range: tuple | None = None
    why: str | None = None


def cutout_curves(m: DutyModel, limits: Limits, heldout: float | None = None, charge=CHARGE_GRID) -> Cutout:
    """Every condition's cut-out speed at every charge, and the danger they make with the limit."""
    curves = tuple(Curve(c, np.asarray(charge, float), np.array([limit_speed(m, float(m.ocv(q)), c) for q in charge]))
                   for c in CONDITIONS)
    return Cutout(curves, heldout, danger_sentence(curves, limits, m.ocv.charge_range), m.ocv.source,
                  m.ocv.charge_range)


@dataclass(frozen=True)
class ChargeEnvelope:
    """What the voltage leaves at one charge, against the envelope's speeds.

    Attributes
    ----------
    voltage : float
        The pack's open-circuit voltage at the charge, V.
    accel : numpy.ndarray
        The acceleration on the level at which the duty reaches 100 %, m/s² (:func:`full_duty_accel`).
    pwm_pct : numpy.ndarray
        The duty that holds each speed steady on the level, %.
    v_limit : float or None
        The speed, m/s, at which the duty reaches 100 % steadily on the level (the cut-out chart's at
        this charge): above it nothing is left; None when the envelope's speeds end first.
    """

    voltage: float
    accel: np.ndarray
    pwm_pct: np.ndarray
    v_limit: float | None

    @property
    def lean(self) -> np.ndarray:
        """The forward lean :attr:`accel` takes, rad."""
        return np.arctan(self.accel / G)


@dataclass(frozen=True)
class Envelope:
    """The ride JSON's ``envelope``: the acceleration and the steady duty the voltage leaves against
    speed at full and empty charge, or why there are none.

    Attributes
    ----------
    speed : numpy.ndarray or None
        The speed readings, m/s.
    full, low : ChargeEnvelope or None
        At 100 % and 0 % of the battery reading.
    voltage_source : str or None
        How the charge gives the voltage (:attr:`OcvLine.source`).
    ride_top_speed : float or None
        The ride's top speed, m/s.
    why : str or None
        Why there is no envelope.
    """

    speed: np.ndarray | None = None
    full: ChargeEnvelope | None = None
    low: ChargeEnvelope | None = None
    voltage_source: str | None = None
    ride_top_speed: float | None = None
    why: str | None = None


def envelope(m: DutyModel, ride_top_speed: float, n: int = 61) -> Envelope:
    """The :class:`Envelope` of the duty model ``m`` on ``n`` speeds from 0 to 10 % past the full charge's
    ``v_limit`` (to twice ``ride_top_speed``, m/s, where there is none); NaN below :data:`SPEED_RANGE`.
    """
    cut = {q: limit_speed(m, float(m.ocv(q)), CONDITIONS[0]) for q in (100.0, 0.0)}
    speed = np.linspace(0.0, 1.1 * cut[100.0] if cut[100.0] > 0 else 2.0 * ride_top_speed, n)

    def at(q: float) -> ChargeEnvelope:
        V = float(m.ocv(q))
        return ChargeEnvelope(V, full_duty_accel(m, speed, V), 100.0 * duty(m, speed, V),
                              cut[q] if cut[q] <= speed[-1] else None)

    return Envelope(speed, at(100.0), at(0.0), m.ocv.source, ride_top_speed)


def danger_sentence(curves, limits: Limits, charge_range: tuple | None = None) -> str | None:
    """Where the cut-out comes before the wheel's speed limit, in one sentence; None where it never does.

    Led by the condition whose cut-out falls under the limit at the highest charge (under it at
    every charge: the one with the lowest cut-out at full charge), the others after it with their
    own charge.  A charge outside ``charge_range`` (the ride's, %) is said to be extrapolated.
    Never states a speed above the limit as available.
    """
    L = limits.speed_limit_mps
    if L is None or not curves:
        return None
    hits = [(q, c) for q, c in ((c.below(L), c) for c in curves) if q is not None]
    if not hits:
        return None
    full = lambda c: float(np.nan_to_num(c.speed_mps[-1], nan=np.inf))        # noqa: E731
    q, c = max(hits, key=lambda h: (h[0], -full(h[1])))
    what = "your tilt-back speed" if limits.source == "log" else "the maker's top speed"
    others = "".join(f"; {o.condition.words}, below {p:.0f} %" if p < o.charge_pct[-1] else
                     f"; {o.condition.words}, at any charge" for p, o in sorted(hits, key=lambda h: -h[0])
                     if o is not c)
    lo = charge_range[0] if charge_range else None
    note = (f" (extrapolated: this ride's charge went no lower than {lo:.0f} %)"
            if lo is not None and q < lo else "")
    if q >= c.charge_pct[-1]:
        return (f"Even at full charge, {c.condition.words}, the motor runs out of voltage (100 % PWM: a cut-out) "
                f"at about {full(c) * 3.6:.0f} km/h, under {what} of {L * 3.6:.0f} km/h{others}.")
    return (f"Below {q:.0f} % charge{note}, {c.condition.words}, the motor runs out of voltage (100 % PWM: "
            f"a cut-out) before {what} of {L * 3.6:.0f} km/h{others}.")


def headroom_words(speed_kmh: float, limits: Limits, cutout_kmh: float | None) -> str:
    """How far under the wheel's limit (or the cut-out, whichever is lower) a speed was, in words.

    Parameters
    ----------
    speed_kmh : float
        The rider's speed, km/h.
    limits : Limits
    cutout_kmh : float or None
        The cut-out speed then, km/h (None: unknown).

    Returns
    -------
    str
        Never a margin above ``limit − speed``.
    """
    cands = [(limits.speed_limit_mps * 3.6, "the wheel's limit")] if limits.speed_limit_mps else []
    if cutout_kmh is not None and np.isfinite(cutout_kmh):
        cands.append((cutout_kmh, "the cut-out speed then"))
    if not cands:
        return "the wheel's limit is not known"
    top, name = min(cands)
    gap = top - speed_kmh
    return f"at or past {name} ({top:.0f} km/h)" if gap < 0.5 else f"{gap:.0f} km/h under {name} ({top:.0f} km/h)"


def heldout_pwm_rmse(sig) -> float | None:
    """The duty model fitted on the ride's first half, its RMS error on the second, percentage points.

    The halves split the rows the duty model uses at their middle time.  None when either
    half has too few of them.
    """
    ok = _pwm_rows(sig)
    if ok.sum() < 400:
        return None
    mid = float(np.median(sig.t[ok]))
    pwm = sig.extra["pwm"]
    first = replace(sig, extra={**sig.extra, "pwm": np.where(sig.t < mid, pwm, np.nan)})
    second = replace(sig, extra={**sig.extra, "pwm": np.where(sig.t >= mid, pwm, np.nan)})
    coef, _ = fit_pwm(first, n_boot=0)
    pred, obs = predict_pwm(second, coef)
    return rms(pred - obs) if pred.size else None


def duty_model(dt, mass, ocv: OcvLine) -> DutyModel:
    """The :class:`DutyModel` of a ride's fits.

    Parameters
    ----------
    dt : Drivetrain
        With its duty model (``pwm_coef``) and battery (``battery_coef``).
    mass : MassFit
        The energy balance: ``coef`` (``inertia`` = m_eq, ``rolling``, ``drag``, ``no_load``,
        ``copper``), ``estimate`` (the mass a slope lifts, kg), ``scale``.
    ocv : OcvLine
    """
    c = mass.coef
    m_eq = float(c.get("inertia") or dt.mass)
    return DutyModel(pwm=dict(dt.pwm_coef), R_int=max(float(dt.battery_coef["R_int"]), 0.0), ocv=ocv,
                     m_eq=m_eq, mass=float(mass.estimate or m_eq), c1=float(c.get("rolling", 0.0)),
                     c3=float(c.get("drag", 0.0)), p0=float(c.get("no_load", 0.0)),
                     copper=float(c.get("copper", 0.0)), copper_column=mass.copper_column,
                     scale=float(mass.scale.estimate))
