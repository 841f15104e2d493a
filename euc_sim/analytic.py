"""The analytic 3-DoF model of the paper, eqs. (5)-(13), vectorised over time.

Generalised coordinates q = (x, gamma, phi): wheel-centre position (m), EUC body
pitch (rad) and rider pitch (rad), signs as in CONTRACT.md.  Every function takes
arrays whose last axis holds the three coordinates, shape ``(3,)`` or ``(N, 3)``,
and returns arrays with the same leading shape; there is no Python loop over
samples.  Torques are arrays broadcastable to the leading shape.

Equations of motion (eq. 5)::

    M(q) q̈ + h(q, q̇) = Q(q, M_d, M_h)
"""

from __future__ import annotations

import numpy as np

from euc_sim.parameters import Params

__all__ = [
    "mass_matrix", "nonlinear_terms", "generalized_forces", "gravity_forces",
    "forward_dynamics", "inverse_dynamics", "driving_torque_1", "driving_torque_2",
    "rider_torque", "kinetic_energy", "potential_energy", "state_derivative",
    "reduced_driving_torque_1", "reduced_driving_torque_2",
]


def _split(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q = np.asarray(q, dtype=float)
    if q.shape[-1] != 3:
        raise ValueError(f"q must have 3 columns (x, gamma, phi), got shape {q.shape}")
    return q[..., 0], q[..., 1], q[..., 2]


def mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    """Mass matrix M(q), eq. (6).

    Parameters
    ----------
    p : Params
        Model parameters.
    q : array_like, shape (..., 3)
        Coordinates (x [m], gamma [rad], phi [rad]).

    Returns
    -------
    numpy.ndarray, shape (..., 3, 3)
        Symmetric mass matrix in SI units (kg, kg·m, kg·m²).
    """
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
    """The vector h(q, q̇) of velocity-dependent terms, eq. (7).

    Parameters
    ----------
    p : Params
    q, qd : array_like, shape (..., 3)
        Coordinates and their rates (m/s, rad/s).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        N, N·m, N·m.
    """
    _, gamma, phi = _split(q)
    _, gamma_d, phi_d = _split(qd)
    h_vec = np.empty(np.broadcast_shapes(gamma.shape, gamma_d.shape) + (3,))
    h_vec[..., 0] = (-p.m * p.h * phi_d**2 * np.sin(phi)                  # eq. (7)
                     + (p.m * p.l0 - p.m0 * p.h0) * gamma_d**2 * np.sin(gamma))
    h_vec[..., 1] = p.m * p.h * p.l0 * phi_d**2 * np.sin(phi - gamma)
    h_vec[..., 2] = -p.m * p.h * p.l0 * gamma_d**2 * np.sin(phi - gamma)
    return h_vec


def generalized_forces(p: Params, q: np.ndarray, M_d=0.0, M_h=0.0) -> np.ndarray:
    """Generalised forces Q(q, M_d, M_h), eq. (8).

    Parameters
    ----------
    p : Params
    q : array_like, shape (..., 3)
    M_d : float or array_like
        Motor driving torque, wheel on EUC body, N·m.
    M_h : float or array_like
        Rider's ankle torque, N·m.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        N, N·m, N·m.
    """
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
    """Accelerations q̈ = M⁻¹ (Q − h), from eq. (5).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        (ẍ [m/s²], γ̈ [rad/s²], φ̈ [rad/s²]).
    """
    rhs = generalized_forces(p, q, M_d, M_h) - nonlinear_terms(p, q, qd)
    return np.linalg.solve(mass_matrix(p, q), rhs[..., None])[..., 0]


def inverse_dynamics(p: Params, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """Generalised actuation forces M q̈ + h − Q_gravity needed for a motion, eq. (5).

    This is the quantity MuJoCo's ``mj_inverse`` returns, mapped to the paper's
    coordinates; it equals Q(q, M_d, M_h) − Q(q, 0, 0) = (M_d/R, M_h − M_d, −M_h)
    when the motion is one the two torques can produce.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        N, N·m, N·m.
    """
    qdd = np.asarray(qdd, dtype=float)
    Mqdd = np.einsum("...ij,...j->...i", mass_matrix(p, q), qdd)
    return Mqdd + nonlinear_terms(p, q, qd) - gravity_forces(p, q)


def driving_torque_1(p: Params, q, qd, qdd) -> np.ndarray:
    """M_d,1: the driving torque from the first row of eq. (5), eq. (9), N·m."""
    return p.R * inverse_dynamics(p, q, qd, qdd)[..., 0]                 # eq. (9)


def driving_torque_2(p: Params, q, qd, qdd) -> np.ndarray:
    """M_d,2: the driving torque with ẍ eliminated using all three rows, eq. (10), N·m.

    Adding rows 2 and 3 of eq. (5) gives −M_d + (gravity) with the ankle torque
    cancelled; eliminating ẍ with row 1 leaves::

        M_d,2 = R [m_11 (G_2 + G_3 − s_2 − s_3) + (m_21 + m_31) s_1] / (m_11 R + m_21 + m_31)

    with s_i = m_i2 γ̈ + m_i3 φ̈ + h_i and G the gravity part of Q.
    """
    M = mass_matrix(p, q)
    s = (np.einsum("...ij,...j->...i", M[..., :, 1:], np.asarray(qdd, float)[..., 1:])
         + nonlinear_terms(p, q, qd))
    G = gravity_forces(p, q)
    m_11 = M[..., 0, 0]
    a = M[..., 1, 0] + M[..., 2, 0]
    return p.R * (m_11 * (G[..., 1] + G[..., 2] - s[..., 1] - s[..., 2]) + a * s[..., 0]) / (
        m_11 * p.R + a)                                                   # eq. (10)


def rider_torque(p: Params, q, qd, qdd) -> np.ndarray:
    """M_h, the rider's ankle torque from the third row of eq. (5), N·m."""
    return -inverse_dynamics(p, q, qd, qdd)[..., 2]


def kinetic_energy(p: Params, q, qd) -> np.ndarray:
    """Kinetic energy T, eq. (A.1), J."""
    qd = np.asarray(qd, dtype=float)
    return 0.5 * np.einsum("...i,...ij,...j->...", qd, mass_matrix(p, q), qd)


def potential_energy(p: Params, q) -> np.ndarray:
    """Gravitational potential energy V, J, with the ground (z = 0) as reference.

    V = g [m (R − l0 cos γ + h cos φ) + m0 (R + h0 cos γ) + mw R]; −∂V/∂q is the
    gravity part of eq. (8).
    """
    _, gamma, phi = _split(q)
    return p.g * (p.m * (p.R - p.l0 * np.cos(gamma) + p.h * np.cos(phi))
                  + p.m0 * (p.R + p.h0 * np.cos(gamma)) + p.mw * p.R)


def state_derivative(p: Params, y: np.ndarray, M_d=0.0, M_h=0.0) -> np.ndarray:
    """d/dt of the state y = (x, γ, φ, ẋ, γ̇, φ̇), for ``scipy.integrate.solve_ivp``."""
    y = np.asarray(y, dtype=float)
    qdd = forward_dynamics(p, y[..., :3], y[..., 3:], M_d, M_h)
    return np.concatenate([y[..., 3:], qdd], axis=-1)


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
