"""The effect catalog: physics the nominal model of the paper leaves out.

Each effect's physics is a generalised force in the paper's coordinates q = (x, gamma,
phi), found by virtual power as in Appendix A:

    δP = Q_e · δq̇  ⇒  M q̈ + h = Q(M_d, M_h) + Q_e.                          (5)+

Effects on a parameter or a measurement act through :func:`apply_to_params` or on the
recording.  The torque-free residual M_d,1 − M_d,2 sees κ(q)·(R Q_e,x + Q_e,γ + Q_e,φ),
the moment about the contact point P, so torques between bodies cancel
(docs/diagnosis.md).  The records themselves are written here (docs/effects.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from euc_sim.errors import InputError
from euc_sim.model.analytic import gravity_forces
from euc_sim.model.catalog import CATALOG as CATALOG_ALL, G, RHO_AIR, Balance, Compare, Conceal, Effect, Words
from euc_sim.model.parameters import Params
from euc_sim.simulation.lateral import (LATERAL_INPUTS, LATERAL_WINDOW, LEAN_INPUTS,  # re-exported
                                        RIDER_MARKER_INPUTS, RIDER_YAW_INERTIA_RATIO, band_peak_tilt,
                                        lateral_force_row, lateral_force_rows, lateral_forces,
                                        rider_lean_forces, rider_spatial_correction, upright_slender_moment)

__all__ = ["PeriodicPush", "Effect", "CATALOG", "RECORDS", "names", "get", "parse_assignment", "checked_value", "bounds_text", "SIGN_SPEED",
           "smooth_sign", "normal_load", "held_forces", "generalized_force", "lateral_forces", "lateral_force_rows", "lateral_force_row", "LATERAL_INPUTS", "LEAN_INPUTS", "RIDER_MARKER_INPUTS", "rider_spatial_correction",
           "LATERAL_WINDOW", "band_peak_tilt",
           "RIDER_YAW_INERTIA_RATIO", "rider_lean_forces", "upright_slender_moment", "apply_to_params"]

#: The contract's simulator effects (those with a ``kind``), by name; filled from :data:`RECORDS` below.
CATALOG: dict[str, Effect] = {}


def names() -> tuple[str, ...]:
    """The catalog's effect names."""
    return tuple(CATALOG)


def get(name: str) -> Effect:
    """The effect called ``name``; ``InputError`` (a ``ValueError``) listing the valid ones otherwise."""
    try:
        return CATALOG[name]
    except KeyError:
        raise InputError(f"unknown effect {name!r}; valid effects: {', '.join(CATALOG)}") from None


def parse_assignment(text: str) -> tuple[str, float]:
    """``"rolling_resistance=0.02"`` → ``("rolling_resistance", 0.02)``, validated."""
    name, sep, value = text.partition("=")
    name = name.strip()
    if not sep:
        raise InputError(f"effect must be given as NAME=VALUE, got {text!r}")
    return name, checked_value(name, value)


def checked_value(name: str, value) -> float:
    """The value (a number or its text) of effect ``name`` as a float, in its unit; ``InputError``
    naming both for an unknown effect or a value outside its ``bounds``.
    """
    e = get(name)
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"effect {name}: expected a number in {e.unit}, got {value!r}") from None
    if not math.isfinite(v):
        raise InputError(f"effect {name}: value must be finite, got {value!r}")
    lo, hi = e.bounds
    if not lo <= v <= hi:
        unit = "" if e.unit == "1" else f" {e.unit}"
        shown = value.strip() if isinstance(value, str) else repr(v)
        raise InputError(f"effect {name}: expected a value in [{lo:g}, {hi:g}]{unit}, got {shown}")
    return v


def bounds_text() -> str:
    """Every effect with the values it may take, for ``--help``: ``rolling_resistance [0, 0.2], ...``."""
    return ", ".join(f"{e.name} [{e.bounds[0]:g}, {e.bounds[1]:g}]{'' if e.unit == '1' else ' ' + e.unit}"
                     for e in CATALOG.values())


#: Speed below which sign(ẋ) is smoothed, m/s (far below riding speeds).
SIGN_SPEED = 0.01


def smooth_sign(v: np.ndarray) -> np.ndarray:
    """tanh(v / :data:`SIGN_SPEED`): sign(v) made continuous within ±SIGN_SPEED."""
    return np.tanh(np.asarray(v, dtype=float) / SIGN_SPEED)


def normal_load(p: Params) -> float:
    """Static normal load of the wheel on level road, (m + m0 + mw)·g, N."""
    return p.total_mass * p.g


def held_forces(x_dot: float, k_drag: float, C_rr: float, N_load: float, R: float,
                F_push: float) -> tuple[float, float]:
    """(F_x at G, N; rolling moment on the wheel, N·m) held over a step, from ẋ (m/s) at its start.

    F_x = −k ẋ|ẋ| + F(t) (``aerodynamic_drag`` k, kg/m; ``external_force`` F, N) and
    τ = −C_rr N R tanh(ẋ / :data:`SIGN_SPEED`).  The one law of every loop (numba-compiled by
    the native callback and the batch): scalars only.
    """
    return (-k_drag * x_dot * abs(x_dot) + F_push,
            -C_rr * N_load * R * math.tanh(x_dot / SIGN_SPEED))


def _gravity_along_road(p: Params, q: np.ndarray) -> np.ndarray:
    """Σ m_i ∂x_i/∂q: the generalised force of a unit horizontal field (per unit g)."""
    q = np.asarray(q, dtype=float)
    gamma, phi = q[..., 1], q[..., 2]
    out = np.empty(q.shape)
    out[..., 0] = p.total_mass
    out[..., 1] = (p.m0 * p.h0 - p.m * p.l0) * np.cos(gamma)
    out[..., 2] = p.m * p.h * np.cos(phi)
    return out


def _rolling_force(value, p, q, qd, extra):
    # moment −C_rr N R sign(ẋ) on the wheel, whose absolute rate is ẋ/R:
    # δP = −C_rr N R sign(ẋ) δẋ/R  ⇒  Q_x = −C_rr N sign(ẋ)
    Q = np.zeros(np.broadcast_shapes(q.shape, qd.shape))
    Q[..., 0] = -value * normal_load(p) * smooth_sign(qd[..., 0])
    return Q


def _drag_force(value, p, q, qd, extra):
    # force F = −k ẋ|ẋ| at G, x_G = x − l0 sin γ + h sin φ: Q = F ∂x_G/∂q
    Q = np.zeros(np.broadcast_shapes(q.shape, qd.shape))
    F = -value * qd[..., 0] * np.abs(qd[..., 0])
    Q[..., 0] = F
    Q[..., 1] = -F * p.l0 * np.cos(q[..., 1])
    Q[..., 2] = F * p.h * np.cos(q[..., 2])
    return Q


def _slope_force(value, p, q, qd, extra):
    # V = g Σ m_i (z_i cos α + x_i sin α); minus the level-ground gravity of eq. (8)
    Q = (np.cos(value) - 1.0) * gravity_forces(p, q) - p.g * np.sin(value) * _gravity_along_road(p, q)
    return np.broadcast_to(Q, np.broadcast_shapes(q.shape, qd.shape)).copy()


def _bearing_force(value, p, q, qd, extra):
    # torque −b ω_rel on the wheel, +b ω_rel on the body, ω_rel = ẋ/R − γ̇
    Q = np.zeros(np.broadcast_shapes(q.shape, qd.shape))
    tau = -value * (qd[..., 0] / p.R - qd[..., 1])
    Q[..., 0] = tau / p.R
    Q[..., 1] = -tau
    return Q


def _lateral_force(value, p, q, qd, extra):
    if extra is None or any(k not in extra for k in LATERAL_INPUTS):
        raise ValueError("lateral_dynamics needs extra with keys " + ", ".join(LATERAL_INPUTS)
                         + f"; got {sorted(extra or {})}")
    Q = lateral_forces(p, q, qd, **{k: extra[k] for k in LATERAL_INPUTS})
    if all(k in extra for k in LEAN_INPUTS):
        Q = Q + rider_lean_forces(p, q, qd, **{k: extra[k] for k in LATERAL_INPUTS + LEAN_INPUTS})
        if all(k in extra for k in RIDER_MARKER_INPUTS):
            Q = Q + rider_spatial_correction(p, q, qd, extra)
    return np.broadcast_to(value * Q, np.broadcast_shapes(q.shape, qd.shape)).copy()


def _rider_mass_params(p: Params, value: float) -> Params:
    # the rider's inertia about G scales with the mass (same body shape)
    return p.replace(m=value, J=p.J * value / p.m)


def generalized_force(name: str, value: float, p: Params, q, qd, extra=None) -> np.ndarray:
    """Generalised force Q_e, (..., 3): (N, N·m, N·m), of effect ``name`` in the paper's coordinates.

    ``value`` in the catalog's unit (``lateral_dynamics``: a scale, 1 the physics); ``q``,
    ``qd`` (..., 3); ``extra`` for ``lateral_dynamics``: the keys of :data:`LATERAL_INPUTS`
    (and :data:`LEAN_INPUTS`, :data:`RIDER_MARKER_INPUTS` where recorded), broadcastable to
    q.  ``ValueError`` for an unknown effect or one without a generalised force.
    """
    e = get(name)
    if e.force is None:
        raise ValueError(f"effect {name!r} ({e.kind}) has no generalised force; "
                         "it acts through the parameters or the recording")
    return e.force(value, p, np.asarray(q, dtype=float), np.asarray(qd, dtype=float), extra)


def apply_to_params(p: Params, name: str, value: float) -> Params:
    """Parameters with a parameter-type effect applied (its record's ``to_params``); others unchanged."""
    e = get(name)
    return p if e.to_params is None else e.to_params(p, value)


# ---------------------------------------------------------------- the ride's faces
# Balance regressors: ``b`` as in :class:`euc_sim.model.catalog.Balance`; signatures ``s`` and pair
# columns as in :class:`euc_sim.model.catalog.Compare`; conceal's ``kin`` as in :class:`~euc_sim.model.catalog.Conceal`.
def _slope_column(b):
    if b.sign_change >= b.sign_change_fraction:
        return b.mg * b.L1(b.v)
    return (f"the speed keeps one sign ({100 * b.sign_change:.1f} % of moving samples the other way): "
            "rolling resistance and a constant road slope give the same column, so only C_rr + sin α "
            "is estimated (as rolling_resistance)")


def _gps_column(b):
    if b.gps_grade is None:
        return "no GPS altitude: road grade unknown; a varying grade stays in the residual"
    return b.mg * b.L1(b.v * b.gps_grade)      # m·g·v·sin α


def _speed_scale_signature(s):
    c = s.coef
    v = np.abs(s.v)
    return (2.0 * c["total_mass"] * s.av + c["rolling_resistance"] * c["total_mass"] * G * v
            + 3.0 * c["aerodynamic_drag"] * v ** 3)


def _asin(s: float) -> float:
    """α, rad, of a grade sin α (clipped to ±1)."""
    return math.asin(max(-1.0, min(1.0, s)))


_COPPER = ("copper loss k_cu·F² of the motor's accelerating or braking force F = m_eq·a "
           "(winding resistance × (R/k_t)²)")
_CDA_PLAUSIBLE = ("C_dA 0.3–1.0 m²: a standing adult 0.8–0.9 m² (Hoerner 1965 ch. 3), an upright cyclist "
                  "0.5–0.7 m² (Wilson & Schmidt 2020 ch. 5)")
RECORDS = CATALOG_ALL
for _e in (
    Effect("total_mass", "m", "kg", "rider plus wheel, the mass the road and the motor move",
           compare=Compare(signature=lambda s: s.av + (0.0 if s.climb is None else np.nan_to_num(s.climb)),
                           pair=lambda sh, m: sh["inertia"] + sh["grade"], coef=80.0, order=2,
                           view="mass_difference"),
           conceal=Conceal("wheel_power", "kg", lambda kin, dm, **kw: dm * (kin.a + G * kin.sin_grade) * kin.v),
           words=Words("mass", "mass", lambda x: x, " kg", "{:.0f}", "more mass", "less mass",
                       "a backpack? a passenger?", "a lighter load?", ("kg more mass", "kg less mass", "{:.0f}"),
                       "rider_weight")),
    Effect("rolling_resistance", "C_rr", "1",
           "resisting moment C_rr·N·R·sign(ẋ) on the wheel from the ground, N the normal load",
           "external", True, plausible=(0.008, 0.04), bounds=(0.0, 0.2), force=_rolling_force,
           balance=Balance("C_rr", "1", "rolling-resistance coefficient, force C_rr·N·sign v "
                           "(in battery power also any loss proportional to speed)", (0.005, 0.05),
                           "tyres on asphalt 0.005–0.02 (Gillespie 1992 ch. 4; Wong ch. 1); 0.05 is rough or loose ground", (0.0, 0.05), 0.01, "column", "rolling", "W",
                           lambda b: b.mg * b.L1(np.abs(b.v))),
           compare=Compare(signature=lambda s: s.coef["total_mass"] * G * np.abs(s.v),
                           pair=lambda sh, m: m * G * sh["rolling"], coef=0.0, order=1),
           conceal=Conceal("wheel_power", "1 (C_rr)",
                           lambda kin, dCrr, total_mass, **kw: dCrr * total_mass * G * np.abs(kin.v)),
           words=Words("rolling resistance", "rolling resistance", lambda c: 100.0 * c, " % of the weight",
                       "{:.1f}", "more rolling resistance", "less rolling resistance",
                       "a softer tyre? a rougher road?", "a harder tyre? a smoother road?",
                       ("more rolling resistance", "less rolling resistance", "{:.3f}"), "tire_pressure")),
    Effect("aerodynamic_drag", "k", "kg/m",
           "force k·ẋ·|ẋ| against the motion, acting at the rider's centre of gravity G",
           "external", True, plausible=(0.15, 0.6), bounds=(0.0, 3.0), force=_drag_force,
           balance=Balance("k", "kg/m", "drag factor ½ρC_dA, force k·v|v| "
                           "(in battery power also any loss growing with |v|³)",
                           (0.5 * RHO_AIR * 0.3, 0.5 * RHO_AIR * 1.0), _CDA_PLAUSIBLE,
                           (0.0, 0.5 * RHO_AIR * 1.0), 0.1, "column", "drag", "m³/s³",
                           lambda b: b.L1(np.abs(b.v) ** 3),
                           json_extra=lambda k, ci: {"drag_area_m2": 2 * k / RHO_AIR,
                                                     "drag_area_m2_ci95": [2 * c / RHO_AIR for c in ci]}),
           compare=Compare(signature=lambda s: np.abs(s.v) ** 3, pair=lambda sh, m: sh["drag"], coef=0.0,
                           order=0),
           conceal=Conceal("wheel_power", "m^2 (C_dA)",
                           lambda kin, dCdA, rho=RHO_AIR, **kw: 0.5 * rho * dCdA * np.abs(kin.v) ** 3),
           words=Words("drag", "drag area", lambda k: k / (0.5 * RHO_AIR), " m²", "{:.2f}", "more drag area",
                       "less drag area", "a jacket? a headwind?", "tighter clothes? a tailwind?",
                       ("kg/m more drag", "kg/m less drag", "{:.2f}"), "wind")),
    Effect("copper_loss", "k_cu", "W/N²", _COPPER,
           balance=Balance("k_cu", "W/N²", _COPPER, (0.0, 0.035),
                           "k_cu = R_w/K_v² with R_w ≤ 0.4 Ω (derived, no published source) and K_v ≥ 3.4 V per m/s", (0.0, 0.035), 0.005, "column", "copper",
                           "N²", lambda b: (b.m_eq * b.L1(b.v, 1)) ** 2,
                           electrical=lambda value, F, v: value * F ** 2)),
    Effect("drivetrain_idle_loss", "P₀", "W", "constant electrical drain (controller, lights)",
           balance=Balance("P₀", "W", "constant electrical drain (controller, lights)", (0.0, 100.0),
                           "a controller and lights; at most the log's standstill power (no published source)", (0.0, 100.0), 10.0, "constant",
                           electrical=lambda value, F, v: value),
           compare=Compare(pair=lambda sh, m: sh["no_load"] * 1.0, named=False)),
    Effect("current_lag", "τ_I", "s", "lag of the logged battery current behind the power drawn",
           balance=Balance("τ_I", "s", "lag of the logged battery current behind the power drawn "
                           "(first-order lag, to second order: logged P ≈ P − τ_I·Ṗ + τ_I²·P̈)", (0.0, 0.3),
                           "a smoothed current report; the second-order expansion departs from the exact lag by 0.4 s",
                           (0.0, 0.3), 0.1, "lag")),
    Effect("road_slope", "α", "rad", "the ground rises by α in +x: gravity tilted by α in the road frame",
           "external", True, plausible=(-0.06, 0.06), bounds=(-0.3, 0.3), force=_slope_force, ref=1e-3,
           detect_range=(0.01, 0.06),
           balance=Balance("sin α", "1", "constant road grade, force m·g·sin α", (-0.15, 0.15),
                           "grades of public roads (no published source)", (-0.15, 0.15), 0.01, "column", "slope", "W", _slope_column,
                           aliases_when_absent=("rolling_resistance",), to_contract=_asin,
                           json_extra=lambda s, ci: {"angle_rad": _asin(s)})),
    Effect("road_slope_gps", "gain", "1", "the road's grade read from GPS altitude",
           balance=Balance("gain", "1", "gain on the climb m·g·v·sin α, the road's grade read from "
                           "GPS altitude over 100 m of road (1 if the altitude were exact, less by "
                           "the share of that grade which is altitude error)", (0.0, 1.5),
                           "1 for exact altitude, less by the share of the GPS grade that is error; "
                           "docs/ride_model.md", (0.0, 1.5), 0.1, column="gps_climb", column_unit="W",
                           regressor=_gps_column, nominal=1.0)),
    Effect("sensor_time_offset", "τ", "s", "the rider channel lags the EUC channels: φ_recorded(t) = φ(t − τ)",
           "measurement", True, plausible=(0.01, 0.1), bounds=(0.0, 0.3)),
    Effect("rider_mass", "m", "kg", "the rider's actual mass differs from the nominal one",
           "parameter", False, needs=("M_d",), plausible=(45.0, 110.0), bounds=(30.0, 200.0),
           to_params=_rider_mass_params, baseline="m", detect_range=(10.0, 30.0),
           hidden_because=("without M_d a wrong rider mass is absorbed by h: a rider leans about a/g "
                           "for an acceleration a whatever he weighs, so the mass shows in M_d,1 − M_d,2 "
                           "only through the EUC's own mass and inertia, near the noise floor")),
    Effect("cog_height_drift", "Δh", "m",
           "h changes during the recording (crouching, standing up); estimate is its peak-to-peak change",
           "parameter", True, plausible=(0.05, 0.25), bounds=(0.0, 0.6)),
    Effect("lateral_dynamics", "ϑ", "rad",
           "yaw and tilt of the pitch plane: yaw acceleration and Coriolis forces on the inward-leaning bodies, gravity g cos ϑ and the turn's centripetal acceleration; with C and G recorded also the rider's lateral lean out of that plane; estimate is the peak tilt",
           "external", True, needs=("psi", "theta"), plausible=(0.05, 0.4), bounds=(0.0, 0.8),
           force=_lateral_force, hidden_because="the recording has no yaw and tilt channels"),
    Effect("wheel_bearing_friction", "b", "N·m·s/rad", "viscous torque b·(ẋ/R − γ̇) between wheel and EUC body",
           "internal", False, needs=("M_d",), plausible=(0.2, 3.0), bounds=(0.0, 30.0), force=_bearing_force,
           hidden_because="it acts between bodies, so it cancels from M_d,1 − M_d,2 (moment about P)"),
    Effect("internal_resistance", "R", "ohm", "the battery pack's internal resistance: V = E − R·I",
           compare=Compare(signature=lambda s: None if s.current is None else s.current ** 2, order=5),
           conceal=Conceal("pack_resistance", "ohm"),
           words=Words("battery resistance", "battery resistance", lambda r: 1000.0 * r, " mΩ", "{:.0f}",
                       "more battery resistance", "less battery resistance", "a colder or older pack?",
                       "a warmer pack?", ("Ω more battery resistance", "Ω less battery resistance", "{:.3f}"),
                       "temperature")),
    Effect("speed_scale", "s", "1", "ground speed over logged wheel speed (the tyre's size as the app knows it)",
           compare=Compare(signature=_speed_scale_signature, ratio=True, order=3),
           conceal=Conceal("speed_scale", "logged/true speed"),
           words=Words("tyre size", "tyre size (speed scale)", lambda s: 100.0 * s, " %", "{:.1f}",
                       "more ground per logged metre", "less ground per logged metre",
                       "a tyre size set differently in the app? a worn tyre?",
                       "a tyre size set differently in the app? a softer tyre?",
                       ("more ground per logged metre", "less ground per logged metre", "{:.1%}"), "tire_pressure")),
    Effect("current_delay", "τ", "s", "the current channel logged late behind the speed",
           compare=Compare(signature=lambda s: -np.gradient(s.P, s.t), order=4),
           conceal=Conceal("channel_delay", "s"),
           words=Words("delay", "current delay", lambda s: s, " s", "{:.1f}", "more delay on the current channel",
                       "less delay on the current channel", "a different app or logging rate?",
                       "a different app or logging rate?",
                       ("s more delay on the current channel", "s less delay on the current channel", "{:.1f}"))),
):
    RECORDS.add(_e)
CATALOG.update({e.name: e for e in RECORDS if e.kind is not None})


@dataclass(frozen=True)
class PeriodicPush:
    """A horizontal force A·sin(2π f t) at the rider's G, N: a picklable disturbance outside the catalog."""

    amplitude: float
    frequency: float

    def __call__(self, t: float) -> float:
        return self.amplitude * math.sin(2.0 * math.pi * self.frequency * t)

    def as_dict(self) -> dict:
        return {"kind": "periodic_push_at_G", "amplitude_N": self.amplitude, "frequency_Hz": self.frequency}
