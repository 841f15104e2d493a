"""The analytic 3-DoF model of the paper, eqs. (5)-(13), vectorised over time.

q = (x [m], gamma [rad], phi [rad]), signs as in CONTRACT.md; every function takes
arrays whose last axis holds the three coordinates (rates in m/s, rad/s), shape ``(3,)``
or ``(N, 3)``, and returns the same leading shape; torques (N·m) broadcast to it.
Generalised forces are (N, N·m, N·m).  Equations of motion (eq. 5)::

    M(q) q̈ + h(q, q̇) = Q(q, M_d, M_h)
"""

from __future__ import annotations

import numpy as np

from euc_sim.model.parameters import Params

__all__ = [
    "mass_matrix", "nonlinear_terms", "generalized_forces", "gravity_forces",
    "forward_dynamics", "inverse_dynamics", "driving_torque_1", "driving_torque_2", "torques",
    "rider_torque", "kinetic_energy", "potential_energy", "state_derivative",
    "reduced_driving_torque_1", "reduced_driving_torque_2",
    "residual_gain", "moment_about_contact", "kinematic_residual",
]


def _split(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q = np.asarray(q, dtype=float)
    if q.shape[-1] != 3:
        raise ValueError(f"q must have 3 columns (x, gamma, phi), got shape {q.shape}")
    return q[..., 0], q[..., 1], q[..., 2]


def mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    """Mass matrix M(q), eq. (6), shape (..., 3, 3), kg, kg·m, kg·m²."""
    _, gamma, phi = _split(q)
    M = np.empty(gamma.shape + (3, 3))
    m_11 = p.m + p.m0 + p.mw + p.Jw / p.R**2                    # eq. (6)
    m_12 = -(p.m * p.l0 - p.m0 * p.h0) * np.cos(gamma)
    m_13 = p.m * p.h * np.cos(phi)
    m_22 = p.J0 + p.m0 * p.h0**2 + p.m * p.l0**2
    m_23 = -p.m * p.h * p.l0 * np.cos(phi - gamma)
    m_33 = p.J + p.m * p.h**2
    M[..., 0, 0] = m_11
    M[..., 0, 1] = M[..., 1, 0] = m_12
    M[..., 0, 2] = M[..., 2, 0] = m_13
    M[..., 1, 1] = m_22
    M[..., 1, 2] = M[..., 2, 1] = m_23
    M[..., 2, 2] = m_33
    return M


def nonlinear_terms(p: Params, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """The velocity-dependent terms h(q, q̇), eq. (7), shape (..., 3)."""
    _, gamma, phi = _split(q)
    _, gamma_d, phi_d = _split(qd)
    h_vec = np.empty(np.broadcast_shapes(gamma.shape, gamma_d.shape) + (3,))
    h_vec[..., 0] = (-p.m * p.h * phi_d**2 * np.sin(phi)                  # eq. (7)
                     + (p.m * p.l0 - p.m0 * p.h0) * gamma_d**2 * np.sin(gamma))
    h_vec[..., 1] = p.m * p.h * p.l0 * phi_d**2 * np.sin(phi - gamma)
    h_vec[..., 2] = -p.m * p.h * p.l0 * gamma_d**2 * np.sin(phi - gamma)
    return h_vec


def generalized_forces(p: Params, q: np.ndarray, M_d=0.0, M_h=0.0) -> np.ndarray:
    """Generalised forces Q(q, M_d, M_h), eq. (8): M_d the motor torque (wheel on body), M_h the ankle torque, N·m."""
    _, gamma, phi = _split(q)
    M_d = np.asarray(M_d, dtype=float)
    M_h = np.asarray(M_h, dtype=float)
    shape = np.broadcast_shapes(gamma.shape, M_d.shape, M_h.shape)
    Q = np.empty(shape + (3,))
    Q[..., 0] = M_d / p.R                                                 # eq. (8)
    Q[..., 1] = M_h - M_d + (p.m0 * p.h0 - p.m * p.l0) * p.g * np.sin(gamma)
    Q[..., 2] = p.m * p.g * p.h * np.sin(phi) - M_h
    return Q


def gravity_forces(p: Params, q: np.ndarray) -> np.ndarray:
    """The gravity part of Q (eq. 8 with M_d = M_h = 0), shape (..., 3)."""
    return generalized_forces(p, q, 0.0, 0.0)


def forward_dynamics(p: Params, q: np.ndarray, qd: np.ndarray, M_d=0.0, M_h=0.0) -> np.ndarray:
    """Accelerations q̈ = M⁻¹ (Q − h), eq. (5): (ẍ [m/s²], γ̈ [rad/s²], φ̈ [rad/s²])."""
    rhs = generalized_forces(p, q, M_d, M_h) - nonlinear_terms(p, q, qd)
    return np.linalg.solve(mass_matrix(p, q), rhs[..., None])[..., 0]


def inverse_dynamics(p: Params, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """M q̈ + h − Q_gravity, eq. (5): what ``mj_inverse`` returns, mapped; equals
    (M_d/R, M_h − M_d, −M_h) for a motion the two torques can produce.
    """
    _, gamma, phi = _split(q)
    _, gamma_d, phi_d = _split(qd)
    x_dd, gamma_dd, phi_dd = _split(qdd)
    # rows of eq. (5) written out (eqs. 6-8) so that no (N, 3, 3) array is built
    cos_g, sin_g = np.cos(gamma), np.sin(gamma)
    cos_p, sin_p = np.cos(phi), np.sin(phi)
    cos_pg = cos_p * cos_g + sin_p * sin_g    # cos(φ − γ), sin(φ − γ) without more trig
    sin_pg = sin_p * cos_g - cos_p * sin_g
    a_g = p.m * p.l0 - p.m0 * p.h0            # −m_12 / cos γ
    mh, mhl0 = p.m * p.h, p.m * p.h * p.l0
    out = np.empty(np.broadcast_shapes(gamma.shape, gamma_d.shape, x_dd.shape) + (3,))
    out[..., 0] = (p.m_eq * x_dd - a_g * cos_g * gamma_dd + mh * cos_p * phi_dd
                   - mh * phi_d**2 * sin_p + a_g * gamma_d**2 * sin_g)
    out[..., 1] = (-a_g * cos_g * x_dd + (p.J0 + p.m0 * p.h0**2 + p.m * p.l0**2) * gamma_dd
                   - mhl0 * cos_pg * phi_dd + mhl0 * phi_d**2 * sin_pg + a_g * p.g * sin_g)
    out[..., 2] = (mh * cos_p * x_dd - mhl0 * cos_pg * gamma_dd + (p.J + mh * p.h) * phi_dd
                   - mhl0 * gamma_d**2 * sin_pg - mh * p.g * sin_p)
    return out


def driving_torque_1(p: Params, q, qd, qdd) -> np.ndarray:
    """M_d,1: the driving torque from the first row of eq. (5), eq. (9), N·m."""
    return p.R * inverse_dynamics(p, q, qd, qdd)[..., 0]                 # eq. (9)


def driving_torque_2(p: Params, q, qd, qdd) -> np.ndarray:
    """M_d,2, eq. (10), N·m: ẍ eliminated with all three rows (it does not depend on the ẍ given).

    With ID = :func:`inverse_dynamics` and a = m_21 + m_31:
    M_d,2 = R (a ID_1 − m_11 (ID_2 + ID_3)) / (m_11 R + a).
    """
    return torques(p, q, qd, qdd)[1]


def torques(p: Params, q, qd, qdd) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M_d,1, M_d,2, M_h) of eqs. (9), (10) and row 3 of eq. (5) in one pass, N·m."""
    ID = inverse_dynamics(p, q, qd, qdd)
    _, gamma, phi = _split(q)
    a = -(p.m * p.l0 - p.m0 * p.h0) * np.cos(gamma) + p.m * p.h * np.cos(phi)   # m_21 + m_31, eq. (6)
    M_d1 = p.R * ID[..., 0]                                                      # eq. (9)
    M_d2 = p.R * (a * ID[..., 0] - p.m_eq * (ID[..., 1] + ID[..., 2])) / (p.m_eq * p.R + a)  # eq. (10)
    return M_d1, M_d2, -ID[..., 2]


def rider_torque(p: Params, q, qd, qdd) -> np.ndarray:
    """M_h, the rider's ankle torque from the third row of eq. (5), N·m."""
    return -inverse_dynamics(p, q, qd, qdd)[..., 2]


def kinetic_energy(p: Params, q, qd) -> np.ndarray:
    """Kinetic energy T, eq. (A.1), J."""
    qd = np.asarray(qd, dtype=float)
    return 0.5 * np.einsum("...i,...ij,...j->...", qd, mass_matrix(p, q), qd)


def potential_energy(p: Params, q) -> np.ndarray:
    """Gravitational potential energy V, J, ground at z = 0:
    V = g [m (R − l0 cos γ + h cos φ) + m0 (R + h0 cos γ) + mw R].
    """
    _, gamma, phi = _split(q)
    return p.g * (p.m * (p.R - p.l0 * np.cos(gamma) + p.h * np.cos(phi))
                  + p.m0 * (p.R + p.h0 * np.cos(gamma)) + p.mw * p.R)


def state_derivative(p: Params, y: np.ndarray, M_d=0.0, M_h=0.0) -> np.ndarray:
    """d/dt of the state y = (x, γ, φ, ẋ, γ̇, φ̇), for ``scipy.integrate.solve_ivp``."""
    y = np.asarray(y, dtype=float)
    qdd = forward_dynamics(p, y[..., :3], y[..., 3:], M_d, M_h)
    return np.concatenate([y[..., 3:], qdd], axis=-1)


# --- what M_d,1 − M_d,2 sees ------------------------------------------------------------
def moment_about_contact(p: Params, Q) -> np.ndarray:
    """R Q_x + Q_γ + Q_φ, N·m: the moment of Q about the contact point P (torques between bodies give 0)."""
    Q = np.asarray(Q, dtype=float)
    return p.R * Q[..., 0] + Q[..., 1] + Q[..., 2]


def residual_gain(p: Params, q) -> np.ndarray:
    """κ(q) = R m_11 / (m_11 R + m_21 + m_31) > 0: an extra force Q_e makes
    M_d,1 − M_d,2 = κ(q) (R Q_e,x + Q_e,γ + Q_e,φ).
    """
    _, gamma, phi = _split(q)
    a = -(p.m * p.l0 - p.m0 * p.h0) * np.cos(gamma) + p.m * p.h * np.cos(phi)   # m_21 + m_31
    return p.R * p.m_eq / (p.m_eq * p.R + a)


def kinematic_residual(p: Params, q, Q_e) -> np.ndarray:
    """M_d,1 − M_d,2 produced by an extra generalised force Q_e, N·m (see residual_gain)."""
    return residual_gain(p, q) * moment_about_contact(p, Q_e)


# --- the reduced 2-DoF model, Section 3.2 ---------------------------------------------
def reduced_driving_torque_1(p: Params, q, qd, qdd) -> np.ndarray:
    """M̄_d,1 of the reduced model, eq. (13), N·m (uses φ, φ̇, ẍ, φ̈ only)."""
    _, _, phi = _split(q)
    _, _, phi_d = _split(qd)
    x_dd, _, phi_dd = _split(qdd)
    return (-p.m * p.h * p.R * np.sin(phi) * phi_d**2 + p.m_eq * p.R * x_dd
            + p.m * p.h * p.R * np.cos(phi) * phi_dd)                    # eq. (13)


def reduced_driving_torque_2(p: Params, q, qd, qdd) -> np.ndarray:
    """M̄_d,2 of the reduced model, eq. (13), N·m (uses φ, φ̇, φ̈ only)."""
    _, _, phi = _split(q)
    _, _, phi_d = _split(qd)
    _, _, phi_dd = _split(qdd)
    m, h, R, m_eq = p.m, p.h, p.R, p.m_eq
    den = m * h * np.cos(phi) + m_eq * R
    return (m_eq * m * p.g * h * R * np.sin(phi)
            - m**2 * h**2 * R * np.sin(phi) * np.cos(phi) * phi_d**2
            + (m**2 * h**2 * R * np.cos(phi)**2 - m_eq * R * (p.J + m * h**2)) * phi_dd) / den  # eq. (13)
