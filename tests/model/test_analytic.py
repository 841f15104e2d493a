"""The analytic model: properties over random states and parameter sets."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from euc_sim.model import analytic as A
from euc_sim.model.parameters import TABLE3, Params

angles = st.floats(-np.pi, np.pi)
rates = st.floats(-10, 10)
params = st.builds(
    Params,
    R=st.floats(0.1, 0.4), m=st.floats(30, 150), m0=st.floats(5, 40), mw=st.floats(1, 10),
    J=st.floats(2, 40), Jw=st.floats(0.02, 0.5), J0=st.floats(0.05, 2), h0=st.floats(0, 0.3),
    l0=st.floats(0, 0.3), h=st.floats(0.2, 1.2))


@settings(max_examples=300, deadline=None)
@given(params, angles, angles)
def test_mass_matrix_symmetric_positive_definite(p, gamma, phi):
    M = A.mass_matrix(p, [0.0, gamma, phi])
    np.testing.assert_array_equal(M, M.T)
    assert np.all(np.linalg.eigvalsh(M) > 0)


@settings(max_examples=200, deadline=None)
@given(params, angles, angles, rates, rates, rates, st.floats(-50, 50), st.floats(-50, 50))
def test_forward_then_inverse_recovers_torques(p, gamma, phi, xd, gd, pd, M_d, M_h):
    q, qd = np.array([0.0, gamma, phi]), np.array([xd, gd, pd])
    qdd = A.forward_dynamics(p, q, qd, M_d, M_h)
    scale = 1.0 + abs(M_d) + abs(M_h) + p.m * p.g * p.h
    assert abs(A.driving_torque_1(p, q, qd, qdd) - M_d) < 1e-9 * scale
    assert abs(A.driving_torque_2(p, q, qd, qdd) - M_d) < 1e-9 * scale
    assert abs(A.rider_torque(p, q, qd, qdd) - M_h) < 1e-9 * scale


def test_vectorised_shapes_and_no_loop_equivalence():
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.normal(size=(3, 50, 3))
    M = A.mass_matrix(TABLE3, q)
    assert M.shape == (50, 3, 3)
    one = np.array([A.driving_torque_2(TABLE3, q[i], qd[i], qdd[i]) for i in range(50)])
    np.testing.assert_allclose(A.driving_torque_2(TABLE3, q, qd, qdd), one, rtol=1e-13)
    with pytest.raises(ValueError, match=r"q must have 3 columns"):
        A.mass_matrix(TABLE3, np.zeros((4, 2)))


def test_reduces_to_2dof_model_when_J0_h0_l0_vanish():
    """eqs. (5)-(8) with J0 = h0 = l0 = 0 are eqs. (11)-(13)."""
    p = TABLE3.reduced()
    rng = np.random.default_rng(1)
    q, qd, qdd = rng.normal(0, 0.5, (3, 200, 3))
    M = A.mass_matrix(p, q)
    assert np.all(M[:, 1, :] == 0) and np.all(M[:, :, 1] == 0)                  # eq. (11)
    np.testing.assert_allclose(M[:, 0, 2], p.m * p.h * np.cos(q[:, 2]))
    h = A.nonlinear_terms(p, q, qd)
    np.testing.assert_allclose(h[:, 1:], 0.0, atol=0)                            # eq. (12)
    np.testing.assert_allclose(A.driving_torque_1(p, q, qd, qdd),
                               A.reduced_driving_torque_1(p, q, qd, qdd), rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(A.driving_torque_2(p, q, qd, qdd),
                               A.reduced_driving_torque_2(p, q, qd, qdd), rtol=1e-12, atol=1e-10)
    # and the full model does differ from the reduced one at Table 3's values
    full = A.driving_torque_2(TABLE3, q, qd, qdd)
    assert np.max(np.abs(full - A.reduced_driving_torque_2(TABLE3, q, qd, qdd))) > 1.0


def test_static_equilibrium_upright():
    """Upright at rest with no torque is an equilibrium; a leaning rider needs M_h = m g h sin φ."""
    z = np.zeros(3)
    np.testing.assert_allclose(A.forward_dynamics(TABLE3, z, z), 0.0, atol=1e-15)
    phi = 0.1
    q = np.array([0.0, 0.0, phi])
    M_h = A.rider_torque(TABLE3, q, z, z)
    assert M_h == pytest.approx(TABLE3.m * TABLE3.g * TABLE3.h * np.sin(phi))


def disc_on_incline():
    """A uniform disc (Jw = mw R²/2) carrying a near-massless body and rider."""
    tiny = 1e-6
    return TABLE3.replace(m=tiny, m0=tiny, J=tiny, J0=tiny, Jw=0.5 * 3.0 * 0.2**2)


def test_disc_rolling_down_an_incline_accelerates_at_two_thirds_g_sin_alpha():
    from euc_sim.simulation.effects import generalized_force
    p, alpha = disc_on_incline(), 0.1
    z = np.zeros(3)
    Q_e = generalized_force("road_slope", alpha, p, z, z)
    qdd = np.linalg.solve(A.mass_matrix(p, z), A.gravity_forces(p, z) + Q_e)
    assert qdd[0] == pytest.approx(-2.0 * p.g * np.sin(alpha) / 3.0, rel=1e-5)


def test_energy_conserved_by_passive_dynamics():
    from scipy.integrate import solve_ivp
    p = TABLE3
    y0 = np.array([0.0, 0.05, 0.1, 0.5, 0.0, 0.0])
    sol = solve_ivp(lambda t, y: A.state_derivative(p, y), (0, 3), y0, rtol=1e-11, atol=1e-11,
                    method="DOP853", dense_output=True)
    Y = sol.sol(np.linspace(0, 3, 300)).T
    E = A.kinetic_energy(p, Y[:, :3], Y[:, 3:]) + A.potential_energy(p, Y[:, :3])
    assert np.max(np.abs(E - E[0])) / abs(E[0]) < 1e-8
    assert np.max(np.abs(Y[:, 2])) > 1.0      # the rider did fall: the test saw real motion


def test_kinematic_residual_of_an_external_force():
    """M_d,1 − M_d,2 = κ (R Q_x + Q_γ + Q_φ) for any extra generalised force."""
    p = TABLE3
    rng = np.random.default_rng(5)
    q, qd = rng.normal(0, 0.3, (2, 40, 3))
    Q_e = rng.normal(0, 5, (40, 3))
    qdd = np.linalg.solve(A.mass_matrix(p, q),
                          (A.generalized_forces(p, q, 10.0, -5.0) + Q_e - A.nonlinear_terms(p, q, qd))[..., None])[..., 0]
    r = A.driving_torque_1(p, q, qd, qdd) - A.driving_torque_2(p, q, qd, qdd)
    np.testing.assert_allclose(r, A.kinematic_residual(p, q, Q_e), atol=1e-10)
    assert np.all(A.residual_gain(p, q) > 0)
