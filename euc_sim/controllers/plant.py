"""The linear plant the rider balances, and the rows of his delay-compensating predictor.

The linearisation of eq. (5) (:func:`euc_sim.model.linearize.jacobians`) at upright
riding with the motor PD closed inside, reduced to s = (ẋ, γ, φ, γ̇, φ̇) (x is cyclic)
and driven by M_h:

    ṡ = A_s s + B_s M_h,   A_s = (A + B_d K_motor)|_s,   B_s = B_h|_s.
"""

from __future__ import annotations

import numpy as np

from euc_sim.controllers.lateral import lateral_predictor_rows
from euc_sim.controllers.motor import MotorPD
from euc_sim.model.linearize import REDUCED_STATE, discretize, jacobians, motor_feedback_row
from euc_sim.model.parameters import Params, TABLE3

__all__ = ["linear_plant", "rider_plant", "has_integral", "predictor_rows", "speed_zero"]


def linear_plant(p: Params = TABLE3, motor: MotorPD | None = None,
                 speed: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(A_s (5, 5), B_s (5, 1)) with the motor PD inside at ``speed``, m/s; input M_h, N·m."""
    motor = motor or MotorPD()
    y0 = np.zeros(6)
    y0[3] = speed
    A, B = jacobians(p, y0)
    Km = motor_feedback_row(motor.Kp, motor.Kd, motor.dgamma_ref_dv(speed))
    Am = A + B[:, [0]] @ Km
    idx = list(REDUCED_STATE)
    return Am[np.ix_(idx, idx)], B[idx][:, [1]]


def rider_plant(p: Params = TABLE3, motor: MotorPD | None = None, integral: bool = True,
                speed: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """:func:`linear_plant` with ∫(ẋ − v_ref) dt (m, ż = s_0) appended as a sixth state when ``integral``."""
    A, B = linear_plant(p, motor, speed)
    if not integral:
        return A, B
    Aa = np.zeros((6, 6))
    Aa[:5, :5] = A
    Aa[5, 0] = 1.0
    return Aa, np.vstack([B, [[0.0]]])


def has_integral(K) -> bool:
    n = np.asarray(K).size
    if n not in (5, 6):
        raise ValueError(f"rider gains must have 5 or 6 entries, got {n}")
    return n == 6


def predictor_rows(p: Params, motor: MotorPD, K, dt: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """K Φⁿ ((5,) or (6,)) and (K Φ^{n−1} Γ, …, K Γ) ((n,), oldest first): the predictor
    ŝ_k = Φⁿ s_{k−n} + Σ_{i<n} Φ^{n−1−i} Γ δu_{k−n+i} premultiplied by K, (Φ, Γ) the ZOH
    discretisation at ``dt``, s.
    """
    A, B = rider_plant(p, motor, has_integral(K))
    KPn, KG = lateral_predictor_rows(*discretize(A, B, dt), np.asarray(K, dtype=float).reshape(1, -1), n)
    return KPn.ravel(), KG.ravel()


def speed_zero(p: Params = TABLE3, motor: MotorPD | None = None) -> float:
    """The right-half-plane zero z of the wheel speed's response to the ankle torque, rad/s.

    To speed up, the wheel must first run back under the rider: M_h → ẋ of
    :func:`linear_plant` has a real zero z > 0, the invariant zero of (A_s, B_s, e_ẋ), which
    bounds speed tracking to ω_B < z/2 (Skogestad and Postlethwaite, 2005, §5.6).  ``nan``
    when there is no real right-half-plane zero.
    """
    from scipy.linalg import eigvals

    A, B = linear_plant(p, motor)
    n = A.shape[0]
    C = np.zeros((1, n))
    C[0, 0] = 1.0                                            # ẋ
    pencil = np.block([[A, B], [C, np.zeros((1, 1))]])
    E = np.zeros((n + 1, n + 1))
    E[:n, :n] = np.eye(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = eigvals(pencil, E)
    z = z[np.isfinite(z)]
    z = z[(np.abs(z.imag) < 1e-9 * np.maximum(1.0, np.abs(z))) & (z.real > 1e-9)].real
    return float(z.min()) if z.size else float("nan")
