"""The yaw and tilt of a turning EUC acting on its pitch plane (the ``lateral_dynamics`` effect).

The tilted, turning plane's generalised force on the paper's coordinates
(:func:`lateral_forces`; per step :func:`lateral_force_row`), the rider's lateral lean
(:func:`rider_lean_forces`), his spatial correction from the G marker
(:func:`rider_spatial_correction`), the upright slender rider's term
(:func:`upright_slender_moment`) and the tilt the effect is scored against
(:func:`band_peak_tilt`).  :mod:`effects` re-exports every name.  See docs/diagnosis.md
(Lateral dynamics) and docs/spatial.md.
"""

from __future__ import annotations

import numpy as np

from euc_sim.errors import InputError
from euc_sim.model.parameters import Params
from euc_sim.model.rider_spatial import rider_translation_forces

#: The tilt and yaw signals the ``lateral_dynamics`` term needs (rad, rad/s, rad/s²).
LATERAL_INPUTS = ("theta", "theta_d", "psi_d", "psi_dd")

#: The couplings' bandwidth: the window, s, of the cubic Savitzky–Golay fit of tilt and yaw
#: (docs/spatial.md).
LATERAL_WINDOW = 0.5


def band_peak_tilt(theta, dt: float, window: float = LATERAL_WINDOW) -> float:
    """``lateral_dynamics``' peak tilt (CONTRACT), rad: max |ϑ| over the couplings' bandwidth.

    The tilt ``theta`` (rad, sampled every ``dt`` s) smoothed by the cubic Savitzky–Golay fit
    of ``window`` s through which the couplings act, its peak over the samples a half window
    from either end: the rider's wobble left out.  Gives both a simulation's truth and the
    diagnosis's estimate.  ``InputError`` for a record shorter than two windows.
    """
    from scipy.signal import savgol_filter
    theta = np.asarray(theta, dtype=float)
    w = int(round(window / dt)) | 1
    if theta.ndim != 1 or theta.size < 2 * w:
        raise InputError(f"theta: expected a 1-D tilt of at least {2 * w} samples (two {window:g} s "
                         f"windows at dt = {dt:g} s), got shape {theta.shape}")
    e = w // 2
    return float(np.max(np.abs(savgol_filter(theta, w, 3, mode="interp")[e:theta.size - e])))


def min_duration() -> float:
    """Shortest record, s, whose tilt :func:`band_peak_tilt` can read (two windows at 1 kHz)."""
    return (2 * (int(round(LATERAL_WINDOW / 1e-3)) | 1) - 1) * 1e-3


def lateral_forces(p: Params, q, qd, theta, theta_d, psi_d, psi_dd) -> np.ndarray:
    """Generalised force of yaw and tilt on the pitch plane (``lateral_dynamics``).

    The plane rides on the EUC (origin P at the contact, speed ẋ, heading ψ) tilted by
    ϑ_l = −ϑ to the left.  A body point at (ξ, ζ) in the plane gains, along e_f and e_u,

        δa_f = −ξ ψ̇² − 2 ζ̇ ψ̇ sin ϑ_l − ζ (2 ϑ̇_l ψ̇ cos ϑ_l + ψ̈ sin ϑ_l),
        δa_u = (ẋ + 2 ξ̇) ψ̇ sin ϑ_l + ξ ψ̈ sin ϑ_l − ζ (ϑ̇_l² + ψ̇² sin² ϑ_l) + g (cos ϑ_l − 1),

    and each pitch rate −ψ̇ sin ϑ_l; by Kane's method, Q_i = −Σ_b m_b (δa_f ∂ξ_b/∂q_i +
    δa_u ∂ζ_b/∂q_i) + Σ_b J_b (ψ̈ sin ϑ_l + ψ̇ ϑ̇_l cos ϑ_l) ∂ω_b/∂q̇_i.  Only the pitch
    inertias (Table 3) are known: other gyroscopic terms are left out.  Proven against
    ``euc_sim.model.symbolic.derive_lateral``.

    Parameters
    ----------
    p : Params
    q, qd : array_like, shape (..., 3)
        Paper coordinates and rates (x the distance run along the path).
    theta, theta_d : array_like
        Tilt ϑ, rad, positive to the right (CONTRACT, eq. 2), and its rate, rad/s.
    psi_d, psi_dd : array_like
        Yaw rate ψ̇, rad/s, and acceleration ψ̈, rad/s².

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        (N, N·m, N·m) to add to the right-hand side of eq. (5).
    """
    q = np.asarray(q, dtype=float)
    qd = np.asarray(qd, dtype=float)
    gamma, phi, th = q[..., 1], q[..., 2], np.asarray(theta, dtype=float)
    rows = lateral_force_rows(p, np.sin(gamma), np.cos(gamma), np.sin(phi), np.cos(phi),
                              qd[..., 0], qd[..., 1], qd[..., 2], np.sin(th), np.cos(th),
                              np.asarray(theta_d, dtype=float), np.asarray(psi_d, dtype=float),
                              np.asarray(psi_dd, dtype=float))
    Q = np.zeros(np.broadcast_shapes(*(np.shape(r) for r in rows)) + (3,))
    Q[..., 0], Q[..., 1], Q[..., 2] = rows
    return Q


def lateral_force_rows(p: Params, s_gamma, c_gamma, s_phi, c_phi, x_d, gamma_d, phi_d,
                       s_theta, c_theta, theta_d, psi_d, psi_dd) -> tuple:
    """(Q_x, Q_γ, Q_φ) of :func:`lateral_forces` from the angles' sines and cosines, floats or arrays alike."""
    return lateral_force_row(p.mw, p.m0, p.m, p.h0, p.l0, p.h, p.R, p.g, p.Jw, p.J0, p.J,
                             s_gamma, c_gamma, s_phi, c_phi, x_d, gamma_d, phi_d,
                             s_theta, c_theta, theta_d, psi_d, psi_dd)


def lateral_force_row(mw, m0, m, h0, l0, h, R, g, Jw, J0, J, s_gamma, c_gamma, s_phi, c_phi, x_d, gamma_d,
                      phi_d, s_theta, c_theta, theta_d, psi_d, psi_dd) -> tuple:
    """:func:`lateral_force_rows` with Table 3's parameters as numbers (kg, m, kg·m², m/s²): the one
    law of every loop (numba-compiled by the native callback), arithmetic only.
    """
    sg, cg, sp_, cp = s_gamma, c_gamma, s_phi, c_phi
    # CONTRACT's ϑ (eq. 2) is positive tilting to the right; the derivation below leans
    # the plane by ϑ_l = −ϑ towards the left, the side a turn with ψ̇ > 0 goes to
    s_th, c_th, th_d, ps_d, ps_dd = -s_theta, c_theta, -theta_d, psi_d, psi_dd
    # δa_f = −ξ ψ̇² − 2 ζ̇ ψ̇ sin ϑ_l − ζ k_f;  δa_u = (ẋ + 2 ξ̇) ψ̇ sin ϑ_l + ξ ψ̈ sin ϑ_l − ζ k_u + g_u
    k_f = 2.0 * th_d * ps_d * c_th + ps_dd * s_th
    k_u = th_d**2 + ps_d**2 * s_th**2
    g_u = g * (c_th - 1.0)
    # wheel centre C at (ξ, ζ) = (0, R), fixed in the plane: only δa_f moves x
    fa_w = -R * k_f
    # EUC body G0: (ξ, ζ) = (h0 sin γ, R + h0 cos γ)
    xi, zeta, xi_d, zeta_d = h0 * sg, R + h0 * cg, h0 * cg * gamma_d, -h0 * sg * gamma_d
    fa_0 = -xi * ps_d**2 - 2.0 * zeta_d * ps_d * s_th - zeta * k_f
    ua_0 = (x_d + 2.0 * xi_d) * ps_d * s_th + xi * ps_dd * s_th - zeta * k_u + g_u
    # rider G: (ξ, ζ) = (−l0 sin γ + h sin φ, R − l0 cos γ + h cos φ)
    xi, zeta = -l0 * sg + h * sp_, R - l0 * cg + h * cp
    xi_d, zeta_d = -l0 * cg * gamma_d + h * cp * phi_d, l0 * sg * gamma_d - h * sp_ * phi_d
    fa_1 = -xi * ps_d**2 - 2.0 * zeta_d * ps_d * s_th - zeta * k_f
    ua_1 = (x_d + 2.0 * xi_d) * ps_d * s_th + xi * ps_dd * s_th - zeta * k_u + g_u
    spin = ps_dd * s_th + ps_d * th_d * c_th          # −d/dt of the pitch rate's −ψ̇ sin ϑ
    # Q_i = −Σ m_b (δa_f ∂ξ_b/∂q_i + δa_u ∂ζ_b/∂q_i) + J_b spin ∂ω_b/∂q̇_i; ∂ξ/∂x = 1 (P moves
    # with x), the wheel turns at ẋ/R
    Q_x = -(mw * fa_w + m0 * fa_0 + m * fa_1) + Jw / R * spin
    Q_gamma = (-m0 * (fa_0 * (h0 * cg) + ua_0 * (-h0 * sg)) - m * (fa_1 * (-l0 * cg) + ua_1 * (l0 * sg))
               + J0 * spin)
    Q_phi = -m * (fa_1 * (h * cp) + ua_1 * (-h * sp_)) + J * spin
    return Q_x, Q_gamma, Q_phi


#: The rider's lateral lean relative to the EUC body, its rates and the tilt
#: acceleration (rad, rad/s, rad/s², rad/s²) that :func:`rider_lean_forces` needs.
LEAN_INPUTS = ("lean", "lean_d", "lean_dd", "theta_dd")
#: The rider's inertia about his long axis over J (a standing body is slender); the spatial
#: model uses the same ratio.
RIDER_YAW_INERTIA_RATIO = 0.2


def rider_lean_forces(p: Params, q, qd, theta, theta_d, psi_d, psi_dd, lean, lean_d, lean_dd, theta_dd) -> np.ndarray:
    """Generalised force of the rider's lateral lean λ relative to the EUC body.

    A rider leaning by λ about his ankle's fore-aft axis (after his pitch φ; λ > 0 to the
    right) has G out of the plane by y = −h sin λ and an in-plane arm h cos λ.  By Kane's
    method: the translation of that offset and arm change in the turning, tilted frame, and
    the rotation of the rider's inertia I = J 1 + (J_z − J) n nᵀ about G (J_z =
    :data:`RIDER_YAW_INERTIA_RATIO` · J), less the upright slender term
    (:func:`upright_slender_moment`) that :func:`lateral_forces` leaves out.  Exact at λ = 0
    and to first order in λ (``euc_sim.model.symbolic.derive_rider_lean``).

    Parameters
    ----------
    p : Params
    q, qd : array_like, shape (..., 3)
    theta, theta_d, theta_dd : array_like
        EUC tilt ϑ (CONTRACT, positive to the right), rad, and its rates.
    psi_d, psi_dd : array_like
        Yaw rate, rad/s, and acceleration, rad/s².
    lean, lean_d, lean_dd : array_like
        The rider's lean λ relative to the EUC body, rad, and its rates.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        (N, N·m, N·m) to add to the right-hand side of eq. (5).
    """
    q = np.asarray(q, dtype=float)
    qd = np.asarray(qd, dtype=float)
    gamma, phi, phi_d = q[..., 1], q[..., 2], qd[..., 2]
    th, th_d, th_dd = (np.asarray(a, dtype=float) for a in (theta, theta_d, theta_dd))
    ps_d, ps_dd = np.asarray(psi_d, dtype=float), np.asarray(psi_dd, dtype=float)
    lam, lam_d = np.asarray(lean, dtype=float), np.asarray(lean_d, dtype=float)
    s_th, c_th, s_l, c_l, s_p, c_p = np.sin(th), np.cos(th), np.sin(lam), np.cos(lam), np.sin(phi), np.cos(phi)
    # translation of the out-of-plane offset y = −h sin λ
    y, y_d = -p.h * s_l, -p.h * c_l * lam_d
    a_f = y * (-ps_dd * c_th + 2.0 * th_d * ps_d * s_th) - 2.0 * y_d * ps_d * c_th
    a_u = y * (th_dd + ps_d**2 * s_th * c_th) + 2.0 * y_d * th_d
    # in-plane arm h cos λ instead of h: c = cos λ − 1 and its rates
    c, c_d = c_l - 1.0, -s_l * lam_d
    c_dd = -c_l * lam_d**2 - s_l * np.asarray(lean_dd, dtype=float)
    a_f = a_f + p.h * (c_dd * s_p + 2.0 * c_d * phi_d * c_p - c * phi_d**2 * s_p)
    a_u = a_u + p.h * (c_dd * c_p - 2.0 * c_d * phi_d * s_p - c * phi_d**2 * c_p)
    # ... and the frame's rotation acting on that change of arm, as in lateral_force_rows
    d_xi, d_zeta = p.h * c * s_p, p.h * c * c_p
    d_xi_d, d_zeta_d = p.h * (c_d * s_p + c * c_p * phi_d), p.h * (c_d * c_p - c * s_p * phi_d)
    s_tl, t_ld = -s_th, -th_d                       # the left tilt ϑ_l = −ϑ of lateral_force_rows
    a_f = a_f - d_xi * ps_d**2 - 2.0 * d_zeta_d * ps_d * s_tl - d_zeta * (2.0 * t_ld * ps_d * c_th + ps_dd * s_tl)
    a_u = a_u + 2.0 * d_xi_d * ps_d * s_tl + d_xi * ps_dd * s_tl - d_zeta * (t_ld**2 + ps_d**2 * s_tl**2)
    Q = np.zeros(np.broadcast_shapes(q.shape, np.shape(lam) + (3,), np.shape(th) + (3,)))
    Q[..., 0] = -p.m * a_f
    Q[..., 1] = -p.m * (a_f * (-p.l0 * np.cos(gamma)) + a_u * p.l0 * np.sin(gamma))
    Q[..., 2] = -p.m * (a_f * p.h * c_p - a_u * p.h * s_p)
    # rotation: s = n·ω, ω = Ω + φ̇ e_a + λ̇ e_x', in (e_f, e_a, e_u): Ω = (ϑ̇, ψ̇ sin ϑ, ψ̇ cos ϑ)
    A = c_th * c_l * c_p - s_th * s_l
    s = ps_d * A + th_d * c_l * s_p - phi_d * s_l
    A_d = (-s_th * th_d * c_l * c_p - c_th * s_l * lam_d * c_p - c_th * c_l * s_p * phi_d
           - c_th * th_d * s_l - s_th * c_l * lam_d)
    s_d = (ps_dd * A + ps_d * A_d + th_dd * c_l * s_p
           + th_d * (-s_l * lam_d * s_p + c_l * c_p * phi_d) - phi_d * c_l * lam_d)
    w_f, w_u = th_d + lam_d * c_p, ps_d * c_th - lam_d * s_p
    ea_ndot = -w_f * c_l * c_p + w_u * c_l * s_p
    J, J_z = p.J, RIDER_YAW_INERTIA_RATIO * p.J
    M_rot = J * lam_d * (ps_d * c_th * c_p + th_d * s_p) + (J_z - J) * (-s_l * s_d + s * ea_ndot)
    # less the upright slender rider's own term (λ = λ̇ = λ̈ = 0), which lateral_forces
    # (and so the planar simulator) leaves out with its isotropic rider
    M_rot0 = upright_slender_moment(p, phi, th, th_d, ps_d)
    Q[..., 2] = Q[..., 2] - (M_rot - M_rot0)
    return Q


#: What :func:`rider_spatial_correction` needs beyond :data:`LEAN_INPUTS`: yaw ψ (rad), the
#: rider's centre-of-gravity acceleration G̈ (ground frame, m/s², (N, 3)), ẍ of the distance
#: run and ξ̈, ζ̈ of G in the tilted plane (m/s², ``model.rider_spatial.plane_coordinates``),
#: all through the same smoothing.
RIDER_MARKER_INPUTS = ("psi", "G_dd", "x_dd", "xi_dd", "zeta_dd")


def rider_spatial_correction(p: Params, q, qd, extra: dict) -> np.ndarray:
    """The rider's translation in space where G's marker is recorded, (N, 3): (N, N·m, N·m).

    Replaces the modelled translation of the rider (the m-linear part of
    :func:`lateral_forces` + :func:`rider_lean_forces`) by the one the marker G measures
    (:func:`euc_sim.model.rider_spatial.rider_translation_forces`; docs/spatial.md, the
    ablation).  ``extra`` holds :data:`LATERAL_INPUTS`, :data:`LEAN_INPUTS` and
    :data:`RIDER_MARKER_INPUTS`.
    """
    lat = {k: extra[k] for k in LATERAL_INPUTS}
    lean = {k: extra[k] for k in LATERAL_INPUTS + LEAN_INPUTS}
    p2 = p.replace(m=2.0 * p.m)          # both modelled terms are linear in the rider's mass
    modelled = (lateral_forces(p2, q, qd, **lat) - lateral_forces(p, q, qd, **lat)
                + rider_lean_forces(p2, q, qd, **lean) - rider_lean_forces(p, q, qd, **lean))
    Q = rider_translation_forces(p, q, extra["psi"], extra["theta"], extra["x_dd"], extra["xi_dd"],
                                 extra["zeta_dd"], extra["G_dd"]) - modelled
    return Q


def upright_slender_moment(p: Params, phi, theta, theta_d, psi_d) -> np.ndarray:
    """The upright slender rider's pitch moment about the ankle, N·m.

    (J_z − J)(ψ̇ cos ϑ cos φ + ϑ̇ sin φ)(−ϑ̇ cos φ + ψ̇ cos ϑ sin φ), J_z =
    :data:`RIDER_YAW_INERTIA_RATIO` · J: the slender rider's difference from the isotropic
    one at λ = 0 (the pitch row gets −this).  ``phi``, ``theta`` rad; ``theta_d``, ``psi_d`` rad/s.
    """
    phi, th, th_d, ps_d = (np.asarray(a, dtype=float) for a in (phi, theta, theta_d, psi_d))
    s_p, c_p, c_th = np.sin(phi), np.cos(phi), np.cos(th)
    return (RIDER_YAW_INERTIA_RATIO - 1.0) * p.J * (ps_d * c_th * c_p + th_d * s_p) * (-th_d * c_p + ps_d * c_th * s_p)
