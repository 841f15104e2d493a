"""The rider's translation from his marker (model.rider_spatial) against Kane's method.

Twin test: a rider kept in the EUC's tilted plane (no lean) is moved through a turn in 3-D
(P running on the ground along the heading ψ, the plane tilted by ϑ); his true
acceleration, taken numerically from the 3-D positions, must give through
``rider_translation_forces`` exactly the rider's part of ``effects.lateral_forces``, which
``symbolic.derive_lateral`` proves by Kane's method.
"""

import numpy as np
import pytest

from euc_sim.model.parameters import TABLE3
from euc_sim.model.rider_spatial import plane_coordinates, rider_translation_forces, tilted_axes
from euc_sim.simulation import effects


def _turn(n=6001, dt=1e-3):
    t = np.arange(n) * dt
    x_d = 2.0 + 0.5 * np.sin(1.3 * t)
    psi = 0.4 * t + 0.3 * np.sin(2.1 * t)
    theta = -0.12 + 0.05 * np.sin(1.7 * t + 0.4)
    gamma = 0.03 * np.sin(2.3 * t)
    phi = 0.05 + 0.04 * np.sin(1.9 * t + 1.0)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (x_d[1:] + x_d[:-1]) * dt)])
    return t, dt, x, x_d, psi, theta, gamma, phi


def _positions(p, psi, theta, x_d, gamma, phi, lean, dt):
    """C and G in 3-D: P on the ground along ψ, G at the full arm h tilted out of the plane by λ."""
    e_f, e_u = tilted_axes(psi, theta)
    P = np.zeros((psi.size, 3))
    v = x_d[:, None] * e_f
    P[1:] = np.cumsum(0.5 * (v[1:] + v[:-1]) * dt, axis=0)
    e_a = np.cross(e_u, e_f)
    A = P + (-p.l0 * np.sin(gamma))[:, None] * e_f + (p.R - p.l0 * np.cos(gamma))[:, None] * e_u
    arm = p.h * np.cos(lean)
    G = (A + (arm * np.sin(phi))[:, None] * e_f + (arm * np.cos(phi))[:, None] * e_u
         + (-p.h * np.sin(lean))[:, None] * e_a)
    return P + p.R * e_u, G


def test_plane_coordinates_give_the_planar_models_G_whatever_the_lean():
    p = TABLE3
    t, dt, x, x_d, psi, theta, gamma, phi = _turn(2001)
    lean = 0.1 * np.sin(3.0 * t)
    C, G = _positions(p, psi, theta, x_d, gamma, phi, lean, dt)
    xi, zeta = plane_coordinates(G, C, psi, theta, p.R, gamma, lean, p.l0)
    np.testing.assert_allclose(xi, -p.l0 * np.sin(gamma) + p.h * np.sin(phi), atol=1e-12)
    np.testing.assert_allclose(zeta, p.R - p.l0 * np.cos(gamma) + p.h * np.cos(phi), atol=1e-12)


def test_rider_in_the_plane_reproduces_lateral_forces_rider_terms():
    p = TABLE3
    t, dt, x, x_d, psi, theta, gamma, phi = _turn()
    C, G = _positions(p, psi, theta, x_d, gamma, phi, np.zeros_like(t), dt)
    d = lambda y: np.gradient(y, dt, axis=0)                  # noqa: E731
    q = np.column_stack([x, gamma, phi])
    qd = np.column_stack([x_d, d(gamma), d(phi)])
    xi, zeta = plane_coordinates(G, C, psi, theta, p.R, gamma, np.zeros_like(t), p.l0)
    Q = rider_translation_forces(p, q, psi, theta, d(x_d), d(d(xi)), d(d(zeta)), d(d(G)))
    lat = dict(theta=theta, theta_d=d(theta), psi_d=d(psi), psi_dd=d(d(psi)))
    kane = (effects.lateral_forces(p.replace(m=2 * p.m), q, qd, **lat) - effects.lateral_forces(p, q, qd, **lat))
    inner = slice(50, -50)                                     # np.gradient's one-sided ends
    scale = np.max(np.abs(kane[inner]), axis=0)
    assert np.all(scale > 0.5)                                 # a real coupling, N and N·m
    np.testing.assert_allclose(Q[inner], kane[inner], atol=2e-3 * scale.max())


def test_no_turn_no_force():
    p = TABLE3
    t, dt, x, x_d, psi, theta, gamma, phi = _turn(2001)
    psi, theta = np.zeros_like(t), np.zeros_like(t)
    C, G = _positions(p, psi, theta, x_d, gamma, phi, np.zeros_like(t), dt)
    d = lambda y: np.gradient(y, dt, axis=0)                  # noqa: E731
    xi, zeta = plane_coordinates(G, C, psi, theta, p.R, gamma, np.zeros_like(t), p.l0)
    Q = rider_translation_forces(p, np.column_stack([x, gamma, phi]), psi, theta, d(x_d), d(d(xi)),
                                 d(d(zeta)), d(d(G)))
    assert np.max(np.abs(Q[50:-50])) == pytest.approx(0.0, abs=5e-3)
