"""The rider's centre of gravity moving: h(t) of ``cog_height_drift`` and its ḣ forces.

CONTRACT's ``cog_height_drift=VALUE`` is the peak-to-peak change Δh, m, of h over the
ride, shaped by a :class:`DriftShape`: ``sine`` (default: period 12 s), ``ramp``
(half-cosine by ``sign``·Δh, then held), ``dip`` (1 − cos, there and back), ``wander``
(three seeded sines of periods 6-25 s) or ``profile`` (a cubic spline through knots).

G moving along the rider's axis e = (sin φ, cos φ) adds the inertial forces
Q = −m J_Gᵀ (ḧ e + 2 ḣ φ̇ e⊥), e⊥ = (cos φ, −sin φ), J_G the Jacobian of G's position
(:func:`drift_forces`), added to eq. (8) by the simulator and the diagnosis alike
(docs/diagnosis.md).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from euc_sim.errors import InputError
from euc_sim.model.parameters import Params

__all__ = ["DRIFT_SHAPES", "DriftShape", "parse_drift_shape", "cog_height", "drift_rates", "drift_forces",
           "drift_force_row"]

DRIFT_SHAPES = ("sine", "ramp", "dip", "wander", "profile")
#: Shortest ramp or dip, s: a rider does not crouch by 0.3 m faster than this.
MIN_LENGTH = 1.0


@dataclass(frozen=True)
class DriftShape:
    """Shape of h(t) over the ride (see the module docstring).

    Attributes
    ----------
    kind : str
        One of :data:`DRIFT_SHAPES`.
    start : float
        s from the start of the recording.
    length : float
        Duration of the ramp or dip, period of the sine, s.
    sign : float
        +1: h rises first (standing up), −1: h falls first (crouching).
    seed : int
        Phases of ``wander``.
    knots_t, knots_dh : tuple of float
        ``profile`` only: times (s) and Δh (m).
    """

    kind: str = "sine"
    start: float = 0.0
    length: float = 12.0
    sign: float = 1.0
    seed: int = 0
    knots_t: tuple = ()
    knots_dh: tuple = ()

    def __post_init__(self):
        if self.kind not in DRIFT_SHAPES:
            raise InputError(f"drift shape: kind must be one of {', '.join(DRIFT_SHAPES)}, got {self.kind!r}")
        if not (np.isfinite(self.start) and np.isfinite(self.length)):
            raise InputError(f"drift shape: start and length must be finite, got {self.start!r}, {self.length!r}")
        if self.kind in ("ramp", "dip", "sine") and self.length < MIN_LENGTH:
            raise InputError(f"drift shape: length must be at least {MIN_LENGTH:g} s (a physical crouch), "
                             f"got {self.length!r}")
        if self.sign not in (1.0, -1.0):
            raise InputError(f"drift shape: sign must be +1 or -1, got {self.sign!r}")
        if self.kind == "profile" and (len(self.knots_t) < 4 or len(self.knots_t) != len(self.knots_dh)):
            raise InputError("drift shape: a profile needs at least 4 knots_t and as many knots_dh, "
                             f"got {len(self.knots_t)} and {len(self.knots_dh)}")

    def as_dict(self) -> dict:
        d = asdict(self)
        d["knots_t"], d["knots_dh"] = list(self.knots_t), list(self.knots_dh)
        return d


def parse_drift_shape(text: str) -> DriftShape:
    """``KIND[,key=value...]``, e.g. ``ramp,start=5,length=4,sign=-1`` (the CLI's ``--drift-shape``)."""
    parts = [s.strip() for s in str(text).split(",") if s.strip()]
    if not parts:
        raise InputError(f"--drift-shape: expected KIND[,start=S,length=S,sign=±1,seed=N], got {text!r}")
    kw = {}
    for item in parts[1:]:
        key, sep, val = item.partition("=")
        if not sep or key not in ("start", "length", "sign", "seed"):
            raise InputError(f"--drift-shape: expected start=, length=, sign= or seed=, got {item!r}")
        try:
            kw[key] = int(val) if key == "seed" else float(val)
        except ValueError:
            raise InputError(f"--drift-shape: {key} expects a number, got {val!r}") from None
    return DriftShape(parts[0], **kw)


def _unit_profile(shape: DriftShape, t: np.ndarray) -> np.ndarray:
    """The shape with unit peak-to-peak change (sine: amplitude ½)."""
    u = (t - shape.start) / shape.length
    if shape.kind == "sine":
        return 0.5 * np.sin(2.0 * np.pi * u)
    if shape.kind == "ramp":
        return shape.sign * 0.5 * (1.0 - np.cos(np.pi * np.clip(u, 0.0, 1.0)))
    if shape.kind == "dip":
        inside = (u > 0.0) & (u < 1.0)
        return shape.sign * np.where(inside, 0.5 * (1.0 - np.cos(2.0 * np.pi * u)), 0.0)
    if shape.kind == "wander":
        rng = np.random.default_rng(shape.seed)
        periods = rng.uniform(6.0, 25.0, 3)
        phases = rng.uniform(0.0, 2.0 * np.pi, 3)
        g = sum(np.sin(2.0 * np.pi * t / T + f) / np.sqrt(T) for T, f in zip(periods, phases))
        span = float(np.ptp(g)) if t.size > 1 else 1.0
        return shape.sign * (g - g[0]) / (span if span > 0 else 1.0)
    from scipy.interpolate import CubicSpline
    kt, kd = np.asarray(shape.knots_t, float), np.asarray(shape.knots_dh, float)
    span = float(np.ptp(kd))
    return CubicSpline(kt, kd / (span if span > 0 else 1.0), bc_type="clamped", extrapolate=False)(
        np.clip(t, kt[0], kt[-1]))


def cog_height(h: float, peak_to_peak: float, t, shape: DriftShape | None = None) -> np.ndarray:
    """h(t), m: ``h`` at the start (the sine's mean), m, plus ``peak_to_peak`` Δh, m, times the unit ``shape`` at t, s."""
    t = np.asarray(t, dtype=float)
    return h + peak_to_peak * _unit_profile(shape or DriftShape(), t)


def drift_rates(h_t: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """ḣ (m/s) and ḧ (m/s²) of a sampled h(t) (central differences)."""
    h_d = np.gradient(h_t, dt)
    return h_d, np.gradient(h_d, dt)


def drift_forces(p: Params, q, qd, h, h_d, h_dd) -> np.ndarray:
    """Generalised force of G's motion along the rider's axis, (..., 3): (N, N·m, N·m).

    Q = −m J_Gᵀ (ḧ e + 2 ḣ φ̇ e⊥), added to eq. (5) with h(t) in the mass matrix; ``h``
    (m), ``h_d`` (m/s), ``h_dd`` (m/s²) broadcast to q's leading shape.
    """
    q = np.asarray(q, dtype=float)
    qd = np.asarray(qd, dtype=float)
    gamma, phi, phi_d = q[..., 1], q[..., 2], qd[..., 2]
    s, c = np.sin(phi), np.cos(phi)
    a_x = h_dd * s + 2.0 * h_d * phi_d * c
    a_z = h_dd * c - 2.0 * h_d * phi_d * s
    Q = np.empty(np.broadcast_shapes(q.shape, np.shape(a_x) + (3,)))
    Q[..., 0] = -p.m * a_x
    Q[..., 1] = p.m * p.l0 * (a_x * np.cos(gamma) - a_z * np.sin(gamma))
    Q[..., 2] = -p.m * h * (a_x * c - a_z * s)
    return Q


def drift_force_row(m: float, l0: float, h: float, h_d: float, h_dd: float, gamma: float, phi: float,
                    phi_d: float) -> tuple[float, float, float]:
    """:func:`drift_forces` at one state, in Python floats (the simulator's per-step call)."""
    s, c = math.sin(phi), math.cos(phi)
    a_x = h_dd * s + 2.0 * h_d * phi_d * c
    a_z = h_dd * c - 2.0 * h_d * phi_d * s
    return (-m * a_x, m * l0 * (a_x * math.cos(gamma) - a_z * math.sin(gamma)), -m * h * (a_x * c - a_z * s))
