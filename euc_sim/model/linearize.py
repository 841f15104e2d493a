"""Linearisation of the paper's 3-DoF model (the plant; the controllers designed on it live above it).

State y = (x, γ, φ, ẋ, γ̇, φ̇) (m, rad, rad, m/s, rad/s, rad/s), inputs u = (M_d, M_h)
(N·m), ẏ = f(y, u) = (q̇, M⁻¹(Q − h)) (eq. 5), with the hand-written Jacobians

    ∂q̈/∂q  = M⁻¹ (∂Q/∂q − ∂h/∂q − (∂M/∂q) q̈)
    ∂q̈/∂q̇  = −M⁻¹ ∂h/∂q̇
    ∂q̈/∂u  = M⁻¹ ∂Q/∂u,      ∂Q/∂M_d = (1/R, −1, 0),  ∂Q/∂M_h = (0, 1, −1)

checked against central differences and MuJoCo's ``mjd_transitionFD``.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg

from euc_sim.model import analytic
from euc_sim.model.parameters import Params, TABLE3

__all__ = ["jacobians", "numeric_jacobians", "discretize", "euler_discretize", "check_against_mujoco",
           "motor_feedback_row", "loop_transfer", "delay_margin",
           "REDUCED_STATE"]

#: Indices of the reduced state s = (ẋ, γ, φ, γ̇, φ̇) in y: x is cyclic (no force
#: depends on it), so the rider and the motor never feed it back.
REDUCED_STATE = (3, 1, 2, 4, 5)


def jacobians(p: Params, y, M_d: float = 0.0, M_h: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Analytic Jacobians A = ∂f/∂y (6×6) and B = ∂f/∂u (6×2) of eq. (5) at state ``y``
    (module units) and torques ``M_d``, ``M_h``, N·m.
    """
    y = np.asarray(y, dtype=float)
    if y.shape != (6,):
        raise ValueError(f"y must have shape (6,), got {y.shape}")
    q, qd = y[:3], y[3:]
    _, g, f = q
    _, gd, fd = qd
    a = p.m * p.l0 - p.m0 * p.h0            # m_12 = −a cos γ, eq. (6)
    mh, mhl = p.m * p.h, p.m * p.h * p.l0
    s_fg, c_fg = math.sin(f - g), math.cos(f - g)
    M = analytic.mass_matrix(p, q)
    qdd = analytic.forward_dynamics(p, q, qd, M_d, M_h)

    dM = np.zeros((3, 3, 3))                 # dM[j] = ∂M/∂q_j
    dM[1][0, 1] = dM[1][1, 0] = a * math.sin(g)
    dM[1][1, 2] = dM[1][2, 1] = -mhl * s_fg
    dM[2][0, 2] = dM[2][2, 0] = -mh * math.sin(f)
    dM[2][1, 2] = dM[2][2, 1] = mhl * s_fg

    dh_dq = np.zeros((3, 3))                 # eq. (7)
    dh_dq[:, 1] = (a * gd**2 * math.cos(g), -mhl * fd**2 * c_fg, mhl * gd**2 * c_fg)
    dh_dq[:, 2] = (-mh * fd**2 * math.cos(f), mhl * fd**2 * c_fg, -mhl * gd**2 * c_fg)
    dh_dqd = np.zeros((3, 3))
    dh_dqd[:, 1] = (2 * a * gd * math.sin(g), 0.0, -2 * mhl * gd * s_fg)
    dh_dqd[:, 2] = (-2 * mh * fd * math.sin(f), 2 * mhl * fd * s_fg, 0.0)

    dQ_dq = np.zeros((3, 3))                 # eq. (8)
    dQ_dq[1, 1] = -a * p.g * math.cos(g)
    dQ_dq[2, 2] = mh * p.g * math.cos(f)
    dQ_du = np.array([[1.0 / p.R, 0.0], [-1.0, 1.0], [0.0, -1.0]])

    Mq = np.stack([dM[j] @ qdd for j in range(3)], axis=1)
    A = np.zeros((6, 6))
    A[:3, 3:] = np.eye(3)
    A[3:, :3] = np.linalg.solve(M, dQ_dq - dh_dq - Mq)
    A[3:, 3:] = np.linalg.solve(M, -dh_dqd)
    B = np.zeros((6, 2))
    B[3:, :] = np.linalg.solve(M, dQ_du)
    return A, B


def numeric_jacobians(p: Params, y, M_d: float = 0.0, M_h: float = 0.0,
                      eps: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Central-difference Jacobians of ``analytic.state_derivative`` (a check of :func:`jacobians`)."""
    y = np.asarray(y, dtype=float)
    u = np.array([M_d, M_h], dtype=float)
    A, B = np.zeros((6, 6)), np.zeros((6, 2))
    for i in range(6):
        d = np.zeros(6)
        d[i] = eps
        A[:, i] = (analytic.state_derivative(p, y + d, *u) - analytic.state_derivative(p, y - d, *u)) / (2 * eps)
    for i in range(2):
        d = np.zeros(2)
        d[i] = eps
        B[:, i] = (analytic.state_derivative(p, y, *(u + d)) - analytic.state_derivative(p, y, *(u - d))) / (2 * eps)
    return A, B


def discretize(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretisation of (A, B) at step ``dt``, s: Φ = e^{A dt}, Γ = ∫₀^dt e^{As} ds B."""
    n, m = B.shape
    E = np.zeros((n + m, n + m))
    E[:n, :n], E[:n, n:] = A * dt, B * dt
    F = scipy.linalg.expm(E)
    return F[:n, :n], F[:n, n:]


def euler_discretize(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's semi-implicit Euler step of ẏ = Ay + Bu, y = (q, q̇), at step ``dt``, s:
    q̇' = q̇ + dt q̈, q' = q + dt q̇'.
    """
    n = A.shape[0] // 2
    Aq, Av, Bv = A[n:, :n], A[n:, n:], B[n:]
    eye = np.eye(n)
    Ad = np.block([[eye + dt * dt * Aq, dt * (eye + dt * Av)], [dt * Aq, eye + dt * Av]])
    Bd = np.vstack([dt * dt * Bv, dt * Bv])
    return Ad, Bd


#: Operating point of the MuJoCo check: a generic one (at zero state and torque
#: ``mjd_transitionFD`` returns B = 0).
CHECK_POINT = ((0.0, 0.02, 0.05, 2.0, 0.1, -0.1), (10.0, 5.0))


def check_against_mujoco(p: Params = TABLE3) -> dict:
    """Compare the analytic Jacobians with MuJoCo's ``mjd_transitionFD`` (ideal variant) at
    :data:`CHECK_POINT`, 1 ms step.

    MuJoCo's semi-implicit Euler transition (it does not differentiate RK4), mapped to the
    paper's state (qvel = T q̇, q = S qpos), against :func:`euler_discretize` of (A, B).
    Returns the worst entry errors ``A_max_abs_error``, ``B_max_abs_error``, the largest
    entries ``A_scale``, ``B_scale`` and the larger ratio ``relative_error``.
    """
    import mujoco

    from euc_sim.model.mujoco_model import EucMujoco  # deferred: loads mujoco (0.1 s)

    y, u, dt = np.asarray(CHECK_POINT[0], dtype=float), CHECK_POINT[1], 1e-3
    sim = EucMujoco(p, "ideal", timestep=dt)
    sim.model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    sim.set_state(y[:3], y[3:])
    sim.set_torques(*u)
    mujoco.mj_forward(sim.model, sim.data)
    nv, nu = sim.model.nv, sim.model.nu
    Amj = np.zeros((2 * nv, 2 * nv))
    Bmj = np.zeros((2 * nv, nu))
    mujoco.mjd_transitionFD(sim.model, sim.data, 1e-6, True, Amj, Bmj, None, None)
    T = sim.T                                             # qvel = T q̇ (and qpos tangent)
    S = np.zeros((3, nv))                                  # q = S qpos: x, γ, γ + rider_pitch
    d = sim.index.dof
    S[0, d["x"]] = 1.0
    S[1, d["euc_pitch"]] = 1.0
    S[2, d["euc_pitch"]] = S[2, d["rider_pitch"]] = 1.0
    Tb = scipy.linalg.block_diag(T, T)
    Sb = scipy.linalg.block_diag(S, S)
    act = [mujoco.mj_name2id(sim.model, mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in ("motor", "ankle")]
    A_mj = Sb @ Amj @ Tb
    B_mj = Sb @ Bmj[:, act]
    A, B = jacobians(p, y, *u)
    Ad, Bd = euler_discretize(A, B, dt)
    eA = float(np.max(np.abs(A_mj - Ad)))
    eB = float(np.max(np.abs(B_mj - Bd)))
    sA = float(np.max(np.abs(Ad)))
    sB = float(np.max(np.abs(Bd)))
    return {"A_max_abs_error": eA, "B_max_abs_error": eB, "A_scale": sA, "B_scale": sB,
            "relative_error": max(eA / sA, eB / sB)}


def motor_feedback_row(Kp: float, Kd: float, dgamma_ref_dv: float = 0.0) -> np.ndarray:
    """The motor law M_d = K_p (γ − γ_ref(ẋ)) + K_d γ̇ linearised, as a row on y (1×6)."""
    K = np.zeros((1, 6))
    K[0, 1] = Kp
    K[0, 4] = Kd
    K[0, 3] = -Kp * dgamma_ref_dv
    return K


def loop_transfer(A: np.ndarray, B: np.ndarray, K: np.ndarray, w: np.ndarray) -> np.ndarray:
    """L(jω) = K (jωI − A)⁻¹ B of the loop u = −K s broken at u (SISO), complex (len(w),)."""
    n = A.shape[0]
    eye = np.eye(n)
    return np.array([(K @ np.linalg.solve(1j * wi * eye - A, B))[0, 0] for wi in np.asarray(w)])


def delay_margin(A: np.ndarray, B: np.ndarray, K: np.ndarray) -> tuple[float, float]:
    """Delay margin of the loop u = −K s around ṡ = A s + B u: (τ [s], ω_c [rad/s]).

    The smallest τ = ((arg L(jω_c) + π) mod 2π) / ω_c over the gain crossovers |L(jω_c)| = 1
    (the closed loop without delay stable), searched over 4000 ω from 1e-2 to 1e3 rad/s;
    ``(inf, nan)`` when |L| never crosses 1.
    """
    w = np.logspace(math.log10(1e-2), math.log10(1e3), 4000)
    mag = np.abs(loop_transfer(A, B, K, w)) - 1.0
    best = (math.inf, math.nan)
    for i in np.nonzero(np.diff(np.sign(mag)))[0]:
        lo, hi = math.log(w[i]), math.log(w[i + 1])
        f_lo = mag[i]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            f_mid = abs(loop_transfer(A, B, K, [math.exp(mid)])[0]) - 1.0
            if (f_mid > 0) == (f_lo > 0):
                lo, f_lo = mid, f_mid
            else:
                hi = mid
        wc = math.exp(0.5 * (lo + hi))
        L = loop_transfer(A, B, K, [wc])[0]
        tau = ((np.angle(L) + math.pi) % (2 * math.pi)) / wc
        if tau < best[0]:
            best = (float(tau), float(wc))
    return best
