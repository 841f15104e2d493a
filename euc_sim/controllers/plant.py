"""The linear plant the rider balances, and the rows of his delay-compensating predictor.

The plant is the analytic linearisation of eq. (5) (:func:`euc_sim.model.linearize.jacobians`)
at upright riding, with the motor PD (:class:`euc_sim.controllers.motor.MotorPD`) closed
inside it, reduced to s = (ẋ, γ, φ, γ̇, φ̇) (x is cyclic) and driven by M_h:

    ṡ = A_s s + B_s M_h,   A_s = (A + B_d K_motor)|_s,   B_s = B_h|_s.

Both the rider's law (:mod:`euc_sim.controllers.rider`, the predictor) and the design of
its gains (:mod:`euc_sim.controllers.design`) build on it.
"""

from __future__ import annotations

import numpy as np

from euc_sim.controllers.motor import MotorPD
from euc_sim.model.linearize import REDUCED_STATE, discretize, jacobians, motor_feedback_row
from euc_sim.model.parameters import Params, TABLE3

__all__ = ["linear_plant", "rider_plant", "has_integral", "predictor_rows", "speed_zero"]


def linear_plant(p: Params = TABLE3, motor: MotorPD | None = None,
                 speed: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The linearised plant with the motor PD inside, reduced to (ẋ, γ, φ, γ̇, φ̇).

    Parameters
    ----------
    p : Params
    motor : MotorPD, optional
    speed : float
        Operating speed, m/s.

    Returns
    -------
    A_s : numpy.ndarray, shape (5, 5)
    B_s : numpy.ndarray, shape (5, 1)
        Input M_h, N·m.
    """
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
    """:func:`linear_plant`, with the integral of the speed error appended when ``integral``.

    The sixth state ∫(ẋ − v_ref) dt (m) obeys ż = s_0.

    Returns
    -------
    A : numpy.ndarray, shape (6, 6) or (5, 5)
    B : numpy.ndarray, shape (6, 1) or (5, 1)
    """
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
    """Rows of the delay-compensating predictor, premultiplied by K.

    With Φ, Γ the ZOH discretisation of (A_s, B_s) at dt, the predicted state is
    ŝ_k = Φⁿ s_{k−n} + Σ_{i<n} Φ^{n−1−i} Γ δu_{k−n+i}; the rider applies −K ŝ_k.

    Returns
    -------
    KPn : numpy.ndarray, shape (5,) or (6,)
        K Φⁿ.
    KG : numpy.ndarray, shape (n,)
        (K Φ^{n−1} Γ, …, K Γ): weights of the last n commands, oldest first.
    """
    A, B = rider_plant(p, motor, has_integral(K))
    Phi, Gam = discretize(A, B, dt)
    K = np.asarray(K, dtype=float).reshape(1, -1)
    KG = np.empty(n)
    row = K.copy()                      # K Φ^j, j = 0, 1, ...
    for j in range(n):
        KG[n - 1 - j] = (row @ Gam)[0, 0]
        row = row @ Phi
    return row.ravel(), KG


def speed_zero(p: Params = TABLE3, motor: MotorPD | None = None, speed: float = 0.0) -> float:
    """The right-half-plane zero z of the wheel speed's response to the ankle torque, rad/s.

    To speed up, the rider must lean forward, and to lean forward the wheel must first
    run back under him: the transfer function M_h → ẋ of :func:`linear_plant` has a real
    zero z > 0 (non-minimum phase; about 3.1 rad/s for a 149 kg ride with the paper's
    PD).  It is the invariant zero of (A_s, B_s, C = e_ẋ), the finite generalised
    eigenvalues of the Rosenbrock pencil [[A_s, B_s], [C, 0]] − s [[I, 0], [0, 0]].
    A zero at z bounds the bandwidth of any speed tracking to ω_B < z/2 (Skogestad and
    Postlethwaite, *Multivariable Feedback Control*, 2nd ed., 2005, §5.6):
    :func:`euc_sim.rides.sim.envelope.plan_band_limit` uses it.

    Parameters
    ----------
    p : Params
    motor : MotorPD, optional
    speed : float
        Operating speed, m/s.

    Returns
    -------
    float
        z, rad/s; ``nan`` when the speed response has no real right-half-plane zero.
    """
    from scipy.linalg import eigvals

    A, B = linear_plant(p, motor, speed)
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
