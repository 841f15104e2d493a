"""The rider's translation in space, from his centre of gravity G as the markers see it.

The planar model (eqs. 5-8) carries the rider's centre of gravity G in the EUC's plane,
(ξ, ζ) from the contact point P (x − l0 sin γ + h sin φ − x, R − l0 cos γ + h cos φ), with
gravity g along the plane's up-axis.  In a turn the plane is yawed by ψ and tilted by ϑ, and the rider
leans out of it; ``effects.lateral_forces`` and ``effects.rider_lean_forces`` model
that to first order in his lean.  A recording with G's marker holds the rider's true
acceleration a_G, so the generalised force of everything the plane leaves out of his
translation is known without a model of the lean (Kane's method, the planar partial
velocities ∂r_G/∂q along the tilted axes e_f, e_u; (ξ, ζ) measured from G and C, so that
the nuisance h does not enter the accelerations):

    ΔF = m (a_plane + g e_u) − m (a_G + g e_Z),       a_plane = (ẍ + ξ̈) e_f + ζ̈ e_u,
    Q_x = ΔF·e_f,   Q_γ = ΔF·(−l0 cos γ e_f + l0 sin γ e_u),   Q_φ = ΔF·(h cos φ e_f − h sin φ e_u).

The rider's translation and rotation are the whole remainder ``lateral_dynamics`` leaves
(docs/spatial.md, the ablation); this is the observable half.
"""

from __future__ import annotations

import numpy as np

from euc_sim.model.parameters import Params

__all__ = ["tilted_axes", "plane_coordinates", "rider_translation_forces"]


def tilted_axes(psi, theta) -> tuple[np.ndarray, np.ndarray]:
    """The heading and the tilted up-axis Rz(ψ) Rx(ϑ) e_z, ground frame.

    Parameters
    ----------
    psi : array_like
        Yaw ψ, rad.
    theta : array_like
        Tilt ϑ, rad (CONTRACT's ϑ, eq. 2: positive tilting the top to −y).

    Returns
    -------
    (e_f, e_u) : tuple of numpy.ndarray, shape (..., 3)
        Unit vectors (1).
    """
    psi, theta = np.asarray(psi, dtype=float), np.asarray(theta, dtype=float)
    e_f = np.stack([np.cos(psi), np.sin(psi), np.zeros_like(psi)], axis=-1)
    e_u = np.stack([np.sin(psi) * np.sin(theta), -np.cos(psi) * np.sin(theta), np.cos(theta)], axis=-1)
    return e_f, e_u


def plane_coordinates(G, C, psi, theta, R: float, gamma, lean, l0: float) -> tuple[np.ndarray, np.ndarray]:
    """(ξ, ζ), m: where the planar model puts the rider's centre of gravity, from the markers.

    G seen from the contact point P = C − R e_u in the tilted plane, ρ = G − P, has
    in-plane coordinates (ρ·e_f, ρ·e_u); from the ankle A (ξ_A, ζ_A) = (−l0 sin γ,
    R − l0 cos γ) the in-plane arm is h cos λ at the angle φ.  The planar model, with the
    same φ, puts G at the full arm h: (ξ, ζ) = A + (ρ_in − A)/cos λ, which needs no h.

    Parameters
    ----------
    G, C : array_like, shape (..., 3)
        Ground-frame positions, m.
    psi, theta, gamma, lean : array_like, shape (...)
        Yaw, tilt, the EUC's pitch and the rider's lean λ relative to it, rad.
    R, l0 : float
        Wheel radius and ankle depth below C, m.
    """
    e_f, e_u = tilted_axes(psi, theta)
    rho = np.asarray(G, dtype=float) - np.asarray(C, dtype=float) + R * e_u
    xi_a, zeta_a = -l0 * np.sin(gamma), R - l0 * np.cos(gamma)
    c = np.cos(np.asarray(lean, dtype=float))
    return (xi_a + (np.sum(rho * e_f, axis=-1) - xi_a) / c,
            zeta_a + (np.sum(rho * e_u, axis=-1) - zeta_a) / c)


def rider_translation_forces(p: Params, q, psi, theta, x_dd, xi_dd, zeta_dd, G_dd) -> np.ndarray:
    """Generalised force of the rider's true translation against the planar one, (..., 3).

    The planar model accelerates G by a_plane = (ẍ + ξ̈) e_f + ζ̈ e_u, with (ξ, ζ) where it
    puts G in the plane (:func:`plane_coordinates`, from the markers: no h enters), and
    gravity g along e_u; the markers give the true a_G and gravity along −e_Z.

    Parameters
    ----------
    p : Params
    q : array_like, shape (..., 3)
        Paper coordinates (γ, φ rad enter the partial velocities).
    psi, theta : array_like, shape (...)
        Yaw and tilt, rad.
    x_dd, xi_dd, zeta_dd : array_like, shape (...)
        ẍ of the distance run and ξ̈, ζ̈ of G in the plane, m/s², smoothed like ``G_dd``.
    G_dd : array_like, shape (..., 3)
        The rider's centre-of-gravity acceleration in the ground frame, m/s² (Z up).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        (N, N·m, N·m) to add to the right-hand side of eq. (5).
    """
    q = np.asarray(q, dtype=float)
    G_dd = np.asarray(G_dd, dtype=float)
    sg, cg, sp, cp = np.sin(q[..., 1]), np.cos(q[..., 1]), np.sin(q[..., 2]), np.cos(q[..., 2])
    e_f, e_u = tilted_axes(psi, theta)
    dF_f = p.m * (np.asarray(x_dd) + np.asarray(xi_dd) - np.sum(G_dd * e_f, axis=-1))   # e_Z·e_f = 0
    dF_u = p.m * (np.asarray(zeta_dd) + p.g - np.sum(G_dd * e_u, axis=-1) - p.g * e_u[..., 2])
    Q = np.zeros(np.broadcast_shapes(q.shape, G_dd.shape))
    Q[..., 0] = dF_f
    Q[..., 1] = -p.l0 * cg * dF_f + p.l0 * sg * dF_u
    Q[..., 2] = p.h * cp * dF_f - p.h * sp * dF_u
    return Q
