"""effects.rider_lean_forces against Kane's method done numerically on the rider body
of ``mjcf/euc_3d.xml``'s geometry: G − A = R_t Ry(φ) Rx(λ) (0, 0, h), inertia
diag(J, J, J_z) in the rider's frame, the frame R_t = Rz(ψ) Rx(ϑ) carried by P."""

import numpy as np
from scipy.spatial.transform import Rotation

from euc_sim.model.parameters import TABLE3
from euc_sim.simulation import effects


def _rot(axes: str, *angles):
    """Intrinsic rotations, e.g. ``_rot("ZX", ψ, ϑ)`` = Rz(ψ) Rx(ϑ), shape (N, 3, 3)."""
    r = Rotation.from_euler(axes[:3], np.column_stack(angles[:3]))
    if len(axes) > 3:
        r = r * Rotation.from_euler(axes[3], np.asarray(angles[3])[:, None])
    return r.as_matrix()


def _rider_forces(p, t, x_d, gamma, phi, psi, theta, lean):
    """Generalised inertia and gravity forces of the rider alone, (N, 3), numerically."""
    dt = t[1] - t[0]
    Rt = _rot("ZX", psi, theta)
    e_f, e_a, e_u = Rt[..., 0], Rt[..., 1], Rt[..., 2]
    P = np.cumsum(x_d[:, None] * e_f, axis=0) * dt
    A = P + (p.R - p.l0 * np.cos(gamma))[:, None] * e_u - (p.l0 * np.sin(gamma))[:, None] * e_f
    Rr = _rot("ZXYX", psi, theta, phi, lean)
    G = A + p.h * Rr[..., 2]
    a = np.gradient(np.gradient(G, dt, axis=0), dt, axis=0)
    W = np.gradient(Rr, dt, axis=0) @ np.swapaxes(Rr, -1, -2)
    w = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], -1)
    I = Rr @ np.diag([p.J, p.J, effects.RIDER_YAW_INERTIA_RATIO * p.J]) @ np.swapaxes(Rr, -1, -2)
    dL = np.gradient(np.einsum("nij,nj->ni", I, w), dt, axis=0)
    f = p.m * (a + np.array([0.0, 0.0, p.g]))
    # partial velocities: ∂v_G/∂ẋ = e_f, ∂v_G/∂γ̇ = ∂(G − P)/∂γ, ∂v_G/∂φ̇ = ∂(G − P)/∂φ; ∂ω/∂φ̇ = e_a
    dG_dgamma = p.l0 * (np.sin(gamma)[:, None] * e_u - np.cos(gamma)[:, None] * e_f)
    n0 = np.column_stack([0 * lean, -np.sin(lean), np.cos(lean)])   # Rx(λ) e_z
    dRy_n0 = np.stack([-np.sin(phi) * n0[:, 0] + np.cos(phi) * n0[:, 2], np.zeros_like(phi),
                       -np.cos(phi) * n0[:, 0] - np.sin(phi) * n0[:, 2]], -1)   # (dRy/dφ) n0
    dG_dphi = p.h * np.einsum("nij,nj->ni", Rt, dRy_n0)
    return np.column_stack([np.einsum("ni,ni->n", f, e_f), np.einsum("ni,ni->n", f, dG_dgamma),
                            np.einsum("ni,ni->n", f, dG_dphi) + np.einsum("ni,ni->n", dL, e_a)])


def test_rider_lean_forces_match_kanes_method_on_the_3d_geometry():
    """The force of the lean: the slender rider upright (λ = 0) less the leaning one,
    both by Kane's method done numerically on the 3-D geometry."""
    p = TABLE3
    t = np.arange(0.0, 4.0, 1e-3)
    x_d = 2.0 + 0.3 * np.sin(1.1 * t)
    gamma = 0.03 * np.sin(2.3 * t)
    phi = 0.05 * np.sin(1.7 * t + 0.4)
    psi = 0.5 * t + 0.4 * np.sin(0.9 * t)
    theta = -0.08 + 0.05 * np.sin(1.3 * t)
    lean = -0.07 + 0.06 * np.sin(1.9 * t + 1.0)
    exact = (_rider_forces(p, t, x_d, gamma, phi, psi, theta, np.zeros_like(t))
             - _rider_forces(p, t, x_d, gamma, phi, psi, theta, lean))    # right-hand side of eq. (5)
    d = lambda y, k=1: np.gradient(y, 1e-3) if k == 1 else np.gradient(np.gradient(y, 1e-3), 1e-3)  # noqa: E731
    q = np.column_stack([np.zeros_like(t), gamma, phi])
    qd = np.column_stack([x_d, d(gamma), d(phi)])
    ours = effects.rider_lean_forces(p, q, qd, theta, d(theta), d(psi), d(psi, 2), lean, d(lean), d(lean, 2),
                                     d(theta, 2))
    k = slice(50, -50)
    for row in range(3):
        scale = np.sqrt(np.mean(exact[k, row] ** 2))
        err = np.sqrt(np.mean((ours - exact)[k, row] ** 2))
        # what is left is of second order in the lean (the partial velocities' cos λ, J_z sin²λ φ̈)
        assert scale > 0.1 and err < 0.03 * scale, (row, err, scale)


def test_lateral_dynamics_adds_the_lean_only_when_given():
    p = TABLE3
    q, qd = np.array([0.0, 0.02, 0.03]), np.array([2.0, 0.1, -0.1])
    lat = dict(theta=-0.1, theta_d=0.05, psi_d=0.5, psi_dd=0.3)
    base = effects.generalized_force("lateral_dynamics", 1.0, p, q, qd, lat)
    np.testing.assert_array_equal(base, effects.lateral_forces(p, q, qd, **lat))
    leaned = effects.generalized_force("lateral_dynamics", 1.0, p, q, qd, dict(lat, lean=-0.1, lean_d=0.2, lean_dd=0.3, theta_dd=0.1))
    np.testing.assert_allclose(leaned - base, effects.rider_lean_forces(p, q, qd, lean=-0.1, lean_d=0.2, lean_dd=0.3, theta_dd=0.1, **lat),
                               atol=1e-12)
    assert np.all(np.abs(leaned - base) > 1e-3)
