"""The rider's translation in space, from his centre of gravity G as the markers see it.

Where G's marker is recorded, the generalised force of everything the tilted, turning
plane leaves out of the rider's translation is known without a model of his lean
(Kane's method with the planar partial velocities along the tilted axes e_f, e_u):

    ΔF = m (a_plane + g e_u) − m (a_G + g e_Z),       a_plane = (ẍ + ξ̈) e_f + ζ̈ e_u,
    Q_x = ΔF·e_f,   Q_γ = ΔF·(−l0 cos γ e_f + l0 sin γ e_u),   Q_φ = ΔF·(h cos φ e_f − h sin φ e_u).

See docs/spatial.md (the ablation).
"""

from __future__ import annotations

import numpy as np

from euc_sim.model.parameters import Params

__all__ = ["tilted_axes", "plane_coordinates", "rider_translation_forces"]


def tilted_axes(psi, theta) -> tuple[np.ndarray, np.ndarray]:
    """(e_f, e_u), (..., 3): the heading and the tilted up-axis Rz(ψ) Rx(ϑ) e_z, ground frame, from ψ, ϑ (rad)."""
    psi, theta = np.asarray(psi, dtype=float), np.asarray(theta, dtype=float)
    e_f = np.stack([np.cos(psi), np.sin(psi), np.zeros_like(psi)], axis=-1)
    e_u = np.stack([np.sin(psi) * np.sin(theta), -np.cos(psi) * np.sin(theta), np.cos(theta)], axis=-1)
    return e_f, e_u


def plane_coordinates(G, C, psi, theta, R: float, gamma, lean, l0: float) -> tuple[np.ndarray, np.ndarray]:
    """(ξ, ζ), m: where the planar model puts G, from the markers.

    With ρ = G − P (P = C − R e_u) and the ankle A = (−l0 sin γ, R − l0 cos γ), the planar
    model at the same φ puts G at A + (ρ_in − A)/cos λ: no h needed.  ``G``, ``C`` ground-frame
    positions (..., 3), m; ``psi``, ``theta``, ``gamma``, ``lean`` rad; ``R``, ``l0`` m.
    """
    e_f, e_u = tilted_axes(psi, theta)
    rho = np.asarray(G, dtype=float) - np.asarray(C, dtype=float) + R * e_u
    xi_a, zeta_a = -l0 * np.sin(gamma), R - l0 * np.cos(gamma)
    c = np.cos(np.asarray(lean, dtype=float))
    return (xi_a + (np.sum(rho * e_f, axis=-1) - xi_a) / c,
            zeta_a + (np.sum(rho * e_u, axis=-1) - zeta_a) / c)


def rider_translation_forces(p: Params, q, psi, theta, x_dd, xi_dd, zeta_dd, G_dd) -> np.ndarray:
    """Generalised force of the rider's true translation against the planar one, (..., 3): (N, N·m, N·m).

    ``x_dd``, ``xi_dd``, ``zeta_dd``: ẍ and ξ̈, ζ̈ of G in the plane (:func:`plane_coordinates`),
    m/s²; ``G_dd``: G's ground-frame acceleration (..., 3), m/s², smoothed alike; ``psi``,
    ``theta`` rad.
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
