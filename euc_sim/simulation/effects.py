"""The effect catalog: physics the nominal model of the paper leaves out.

Each effect carries its CONTRACT name, the unit of its estimate, where it acts, and
its physics as a generalised force in the paper's coordinates q = (x, gamma, phi),
found by virtual power as in the paper's Appendix A:

    δP = Q_e · δq̇  ⇒  M q̈ + h = Q(M_d, M_h) + Q_e.                          (5)+

The simulator adds ``Q_e`` to the equations it integrates; the diagnosis turns it into
a candidate term of the residual.  Effects that change a parameter (rider mass,
centre-of-gravity height) or a measurement (time offset of the rider channel) have no
generalised force: they act through :func:`apply_to_params` or on the recording.

What a recording without torques can reveal (docs/diagnosis.md): the driving-torque
residual M_d,1 − M_d,2 equals κ(q)·(R Q_e,x + Q_e,γ + Q_e,φ) (see
:func:`euc_sim.model.analytic.kinematic_residual`): the moment of the extra forces about
the wheel–ground contact point P.  Torques between bodies (motor, ankle, bearing
friction) have R Q_x + Q_γ + Q_φ = 0 and cancel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from euc_sim.errors import InputError
from euc_sim.model.parameters import Params
from euc_sim.simulation.lateral import (LATERAL_INPUTS, LATERAL_WINDOW, LEAN_INPUTS,  # re-exported
                                        RIDER_MARKER_INPUTS, RIDER_YAW_INERTIA_RATIO, band_peak_tilt,
                                        lateral_force_row, lateral_force_rows, lateral_forces,
                                        rider_lean_forces, rider_spatial_correction, upright_slender_moment)

__all__ = ["PeriodicPush", "Effect", "CATALOG", "names", "get", "parse_assignment", "bounds_text", "SIGN_SPEED",
           "smooth_sign", "normal_load", "held_forces", "generalized_force", "lateral_forces", "lateral_force_rows", "lateral_force_row", "LATERAL_INPUTS", "LEAN_INPUTS", "RIDER_MARKER_INPUTS", "rider_spatial_correction",
           "LATERAL_WINDOW", "band_peak_tilt",
           "RIDER_YAW_INERTIA_RATIO", "rider_lean_forces", "upright_slender_moment", "apply_to_params",
           "delay_signal"]

Kind = Literal["external", "internal", "parameter", "measurement"]


@dataclass(frozen=True)
class Effect:
    """One catalogued effect.

    Attributes
    ----------
    name : str
        CONTRACT's name.
    unit : str
        Unit of the estimate.
    physics : str
        One sentence: what acts, where.
    kind : {"external", "internal", "parameter", "measurement"}
        Where it acts: from outside the EUC–rider system, between its bodies, through
        a parameter, or on the recording.
    kinematic_visible : bool
        Whether M_d,1 − M_d,2 (no torque measured) can reveal it.
    needs : tuple of str
        Recording columns needed beyond t, x, gamma, phi.
    plausible : tuple of float
        Range of magnitudes met in practice (for blind studies and plausibility).
    hidden_because : str
        Why a recording without the ``needs`` columns cannot reveal it.
    bounds : tuple of float
        Values an injected effect may take (``--effect NAME=VALUE``), in :attr:`unit`: the
        physical limit beyond which the model of the effect no longer holds; wider than
        :attr:`plausible`, the same as the diagnosis's validity ranges where it has one.
    """

    name: str
    unit: str
    physics: str
    kind: Kind
    kinematic_visible: bool
    needs: tuple[str, ...] = ()
    plausible: tuple[float, float] = (0.0, 0.0)
    hidden_because: str = ""
    bounds: tuple[float, float] = (0.0, 0.0)


CATALOG: dict[str, Effect] = {e.name: e for e in (
    Effect("rolling_resistance", "1",
           "resisting moment C_rr·N·R·sign(ẋ) on the wheel from the ground, N the normal load",
           "external", True, plausible=(0.008, 0.04), bounds=(0.0, 0.2)),
    Effect("aerodynamic_drag", "kg/m",
           "force k·ẋ·|ẋ| against the motion, acting at the rider's centre of gravity G",
           "external", True, plausible=(0.15, 0.6), bounds=(0.0, 3.0)),
    Effect("road_slope", "rad",
           "the ground rises by α in +x: gravity tilted by α in the road frame",
           "external", True, plausible=(-0.06, 0.06), bounds=(-0.3, 0.3)),
    Effect("sensor_time_offset", "s",
           "the rider channel lags the EUC channels: φ_recorded(t) = φ(t − τ)",
           "measurement", True, plausible=(0.01, 0.1), bounds=(0.0, 0.3)),
    Effect("rider_mass", "kg",
           "the rider's actual mass differs from the nominal one",
           "parameter", False, needs=("M_d",), plausible=(45.0, 110.0), bounds=(30.0, 200.0),
           hidden_because=("without M_d a wrong rider mass is absorbed by h: a rider leans about a/g "
                           "for an acceleration a whatever he weighs, so the mass shows in M_d,1 − M_d,2 "
                           "only through the EUC's own mass and inertia, near the noise floor")),
    Effect("cog_height_drift", "m",
           "h changes during the recording (crouching, standing up); estimate is its peak-to-peak change",
           "parameter", True, plausible=(0.05, 0.25), bounds=(0.0, 0.6)),
    Effect("lateral_dynamics", "rad",
           "yaw and tilt of the pitch plane: yaw acceleration and Coriolis forces on the inward-leaning bodies, gravity g cos ϑ and the turn's centripetal acceleration; with C and G recorded also the rider's lateral lean out of that plane; estimate is the peak tilt",
           "external", True, needs=("psi", "theta"), plausible=(0.05, 0.4), bounds=(0.0, 0.8),
           hidden_because="the recording has no yaw and tilt channels"),
    Effect("wheel_bearing_friction", "N·m·s/rad",
           "viscous torque b·(ẋ/R − γ̇) between wheel and EUC body",
           "internal", False, needs=("M_d",), plausible=(0.2, 3.0), bounds=(0.0, 30.0),
           hidden_because="it acts between bodies, so it cancels from M_d,1 − M_d,2 (moment about P)"),
)}


def names() -> tuple[str, ...]:
    """The catalog's effect names."""
    return tuple(CATALOG)


def get(name: str) -> Effect:
    """The effect called ``name``.

    Raises
    ------
    ValueError
        for an unknown name, listing the valid ones.
    """
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
    get(name)
    try:
        v = float(value)
    except ValueError:
        raise InputError(f"effect {name}: expected a number in {CATALOG[name].unit}, got {value!r}") from None
    lo, hi = CATALOG[name].bounds
    if not (np.isfinite(v) and lo <= v <= hi):
        unit = "" if CATALOG[name].unit == "1" else f" {CATALOG[name].unit}"
        raise InputError(f"effect {name}: expected a value in [{lo:g}, {hi:g}]{unit}, got {value.strip()}")
    return name, v


def bounds_text() -> str:
    """Every effect with the values it may take, for ``--help``: ``rolling_resistance [0, 0.2], ...``."""
    return ", ".join(f"{e.name} [{e.bounds[0]:g}, {e.bounds[1]:g}]{'' if e.unit == '1' else ' ' + e.unit}"
                     for e in CATALOG.values())


#: Speed below which sign(ẋ) is smoothed, m/s: a Coulomb moment needs a continuous
#: law to be integrated; 1 cm/s is far below riding speeds.
SIGN_SPEED = 0.01


def smooth_sign(v: np.ndarray, scale: float = SIGN_SPEED) -> np.ndarray:
    """tanh(v / scale): sign(v) made continuous within ±scale."""
    return np.tanh(np.asarray(v, dtype=float) / scale)


def normal_load(p: Params, alpha: float = 0.0) -> float:
    """Static normal load of the wheel on the road, (m + m0 + mw)·g·cos α, N.

    Vertical accelerations of the centres of mass change the load by a few per cent
    in riding; the catalog uses the static value in simulation and diagnosis alike.
    """
    return p.total_mass * p.g * np.cos(alpha)


def held_forces(x_dot: float, k_drag: float, C_rr: float, N_load: float, R: float,
                F_push: float) -> tuple[float, float]:
    """(F_x at G, N; rolling moment on the wheel, N·m) held over a step, from ẋ (m/s) at its start.

    F_x = −k ẋ|ẋ| + F(t) (``aerodynamic_drag`` k in kg/m, an ``external_force`` F(t), N, or 0)
    and τ = −C_rr N R tanh(ẋ / :data:`SIGN_SPEED`) (``rolling_resistance``; N_load from
    :func:`normal_load`, R the wheel radius, m).  The one law of every loop that applies
    them: ``simulate``'s Python loop, and compiled by numba (scalars only) the native
    callback (:mod:`~euc_sim.simulation.native_kernels`) and the batch's
    (:mod:`~euc_sim.simulation.mujoco_batch`).
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


def generalized_force(name: str, value: float, p: Params, q, qd, extra=None) -> np.ndarray:
    """Generalised force Q_e of an effect in the paper's coordinates, by virtual power.

    Parameters
    ----------
    name : str
        An effect with a force: ``rolling_resistance``, ``aerodynamic_drag``,
        ``road_slope``, ``wheel_bearing_friction``, ``lateral_dynamics``.
    value : float
        Its magnitude in the catalog's unit (C_rr; k in kg/m; α in rad; b in N·m·s/rad;
        for ``lateral_dynamics`` a scale, 1 for the physical coupling).
    p : Params
    q, qd : array_like, shape (..., 3)
    extra : dict, optional
        ``lateral_dynamics`` needs the keys of :data:`LATERAL_INPUTS` (see
        :func:`lateral_forces`), broadcastable to q's leading shape; where it also
        has those of :data:`LEAN_INPUTS` (a 3-D recording shows the rider's lateral
        lean), :func:`rider_lean_forces` is added.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        (N, N·m, N·m) to add to the right-hand side of eq. (5).

    Raises
    ------
    ValueError
        for an effect that has no generalised force or an unknown name.
    """
    q = np.asarray(q, dtype=float)
    qd = np.asarray(qd, dtype=float)
    shape = np.broadcast_shapes(q.shape, qd.shape)
    Q = np.zeros(shape)
    x_d, gamma, phi = qd[..., 0], q[..., 1], q[..., 2]
    kind = get(name).kind
    if name == "rolling_resistance":
        # moment −C_rr N R sign(ẋ) on the wheel, whose absolute rate is ẋ/R:
        # δP = −C_rr N R sign(ẋ) δẋ/R  ⇒  Q_x = −C_rr N sign(ẋ)
        Q[..., 0] = -value * normal_load(p) * smooth_sign(x_d)
    elif name == "aerodynamic_drag":
        # force F = −k ẋ|ẋ| at G, x_G = x − l0 sin γ + h sin φ: Q = F ∂x_G/∂q
        F = -value * x_d * np.abs(x_d)
        Q[..., 0] = F
        Q[..., 1] = -F * p.l0 * np.cos(gamma)
        Q[..., 2] = F * p.h * np.cos(phi)
    elif name == "road_slope":
        # V = g Σ m_i (z_i cos α + x_i sin α); minus the level-ground gravity of eq. (8)
        from euc_sim.model.analytic import gravity_forces
        Q = (np.cos(value) - 1.0) * gravity_forces(p, q) - p.g * np.sin(value) * _gravity_along_road(p, q)
        Q = np.broadcast_to(Q, shape).copy()
    elif name == "wheel_bearing_friction":
        # torque −b ω_rel on the wheel, +b ω_rel on the body, ω_rel = ẋ/R − γ̇
        tau = -value * (x_d / p.R - qd[..., 1])
        Q[..., 0] = tau / p.R
        Q[..., 1] = -tau
    elif name == "lateral_dynamics":
        if extra is None or any(k not in extra for k in LATERAL_INPUTS):
            raise ValueError("lateral_dynamics needs extra with keys " + ", ".join(LATERAL_INPUTS)
                             + f"; got {sorted(extra or {})}")
        Q = lateral_forces(p, q, qd, **{k: extra[k] for k in LATERAL_INPUTS})
        if all(k in extra for k in LEAN_INPUTS):
            Q = Q + rider_lean_forces(p, q, qd, **{k: extra[k] for k in LATERAL_INPUTS + LEAN_INPUTS})
            if all(k in extra for k in RIDER_MARKER_INPUTS):
                Q = Q + rider_spatial_correction(p, q, qd, extra)
        Q = np.broadcast_to(value * Q, shape).copy()
    else:
        raise ValueError(f"effect {name!r} ({kind}) has no generalised force; "
                         "it acts through the parameters or the recording")
    return Q


def apply_to_params(p: Params, name: str, value: float) -> Params:
    """Parameters with a parameter-type effect applied (``rider_mass``: m = value).

    Other effects leave the parameters unchanged.
    """
    if get(name).kind != "parameter" or name == "cog_height_drift":
        return p
    if name == "rider_mass":
        # the rider's inertia about G scales with the mass (same body shape)
        return p.replace(m=value, J=p.J * value / p.m)
    raise AssertionError(name)  # pragma: no cover - every parameter effect is handled above


def delay_signal(t: np.ndarray, y: np.ndarray, tau: float) -> np.ndarray:
    """y(t − τ) by linear interpolation, holding the first value before the start.

    The ``sensor_time_offset`` effect applies this to the rider channel φ.
    """
    t = np.asarray(t, dtype=float)
    return np.interp(t - tau, t, np.asarray(y, dtype=float))


@dataclass(frozen=True)
class PeriodicPush:
    """A horizontal force A·sin(2π f t) at the rider's G, N: a disturbance outside the catalog.

    Picklable, so it can travel to worker processes with a :class:`euc_sim.simulation.dataset.RecordingSpec`.
    """

    amplitude: float
    frequency: float

    def __call__(self, t: float) -> float:
        return self.amplitude * math.sin(2.0 * math.pi * self.frequency * t)

    def as_dict(self) -> dict:
        return {"kind": "periodic_push_at_G", "amplitude_N": self.amplitude, "frequency_Hz": self.frequency}
