"""The effect catalog: names as CONTRACT has them, and each generalised force checked
against an independent route to the same physics (finite differences of positions
and potentials, and the moment about the contact point P)."""

import numpy as np

from euc_sim.simulation import drift
import pytest

from euc_sim.model import analytic as A
from euc_sim.simulation import effects as E
from euc_sim.model.parameters import TABLE3 as p

CONTRACT_NAMES = ("rolling_resistance", "aerodynamic_drag", "road_slope", "sensor_time_offset",
                  "rider_mass", "cog_height_drift", "lateral_dynamics", "wheel_bearing_friction")
CONTRACT_UNITS = {"rolling_resistance": "1", "aerodynamic_drag": "kg/m", "road_slope": "rad",
                  "sensor_time_offset": "s", "rider_mass": "kg", "cog_height_drift": "m",
                  "lateral_dynamics": "rad", "wheel_bearing_friction": "N·m·s/rad"}

rng = np.random.default_rng(11)
Q_STATES = rng.normal(0, 0.3, (20, 3))
QD_STATES = rng.normal(0, 2.0, (20, 3))


def test_names_and_units_are_contracts():
    assert E.names() == CONTRACT_NAMES
    assert {n: E.get(n).unit for n in E.names()} == CONTRACT_UNITS


def test_parse_assignment_and_unknown_names():
    assert E.parse_assignment("road_slope=0.03") == ("road_slope", 0.03)
    with pytest.raises(ValueError, match=r"unknown effect 'friction'; valid effects: rolling_resistance"):
        E.parse_assignment("friction=1")
    with pytest.raises(ValueError, match=r"effect aerodynamic_drag: expected a number in kg/m"):
        E.parse_assignment("aerodynamic_drag=lots")
    with pytest.raises(ValueError, match="NAME=VALUE"):
        E.parse_assignment("road_slope")


def _x_G(q):
    return q[..., 0] - p.l0 * np.sin(q[..., 1]) + p.h * np.sin(q[..., 2])


def test_drag_is_a_force_at_G_by_virtual_power():
    k = 0.4
    Q = E.generalized_force("aerodynamic_drag", k, p, Q_STATES, QD_STATES)
    F = -k * QD_STATES[:, 0] * np.abs(QD_STATES[:, 0])
    eps = 1e-6
    for j in range(3):                      # Q_j = F ∂x_G/∂q_j, by central differences
        dq = np.zeros(3)
        dq[j] = eps
        dxG = (_x_G(Q_STATES + dq) - _x_G(Q_STATES - dq)) / (2 * eps)
        np.testing.assert_allclose(Q[:, j], F * dxG, rtol=1e-7, atol=1e-9)


def test_slope_is_the_gradient_of_the_tilted_potential():
    alpha = 0.05

    def V(q):                                # gravity tilted by α in the road frame
        g, f = q[..., 1], q[..., 2]
        z = (p.m * (p.R - p.l0 * np.cos(g) + p.h * np.cos(f)) + p.m0 * (p.R + p.h0 * np.cos(g)) + p.mw * p.R)
        x = p.m * _x_G(q) + p.m0 * (q[..., 0] + p.h0 * np.sin(g)) + p.mw * q[..., 0]
        return p.g * (z * np.cos(alpha) + x * np.sin(alpha))

    eps = 1e-6
    Q_total = A.gravity_forces(p, Q_STATES) + E.generalized_force("road_slope", alpha, p, Q_STATES, QD_STATES)
    for j in range(3):
        dq = np.zeros(3)
        dq[j] = eps
        np.testing.assert_allclose(Q_total[:, j], -(V(Q_STATES + dq) - V(Q_STATES - dq)) / (2 * eps),
                                   rtol=1e-6, atol=1e-6)


def test_rolling_resistance_is_a_moment_on_the_wheel():
    C_rr = 0.02
    Q = E.generalized_force("rolling_resistance", C_rr, p, Q_STATES, QD_STATES)
    N = p.total_mass * p.g
    expected = -C_rr * N * p.R * np.tanh(QD_STATES[:, 0] / E.SIGN_SPEED)
    np.testing.assert_allclose(A.moment_about_contact(p, Q), expected, rtol=1e-12)
    np.testing.assert_array_equal(Q[:, 1:], 0.0)


def test_internal_torque_has_no_moment_about_P():
    Q = E.generalized_force("wheel_bearing_friction", 1.5, p, Q_STATES, QD_STATES)
    np.testing.assert_allclose(A.moment_about_contact(p, Q), 0.0, atol=1e-12)
    # but it does act on the wheel row, which M_d reveals
    assert np.max(np.abs(Q[:, 0])) > 1.0


def _lateral_inputs(n, rng):
    return {"theta": rng.uniform(-0.4, 0.4, n), "theta_d": rng.normal(0, 0.3, n),
            "psi_d": rng.normal(0, 1.0, n), "psi_dd": rng.normal(0, 2.0, n)}


def test_lateral_coupling_vanishes_without_tilt_or_yaw():
    extra = {"theta": np.zeros(20), "theta_d": np.zeros(20), "psi_d": np.zeros(20), "psi_dd": np.zeros(20)}
    Q = E.generalized_force("lateral_dynamics", 1.0, p, Q_STATES, QD_STATES, extra)
    np.testing.assert_array_equal(Q, 0.0)
    with pytest.raises(ValueError, match="lateral_dynamics needs extra with keys theta, theta_d"):
        E.generalized_force("lateral_dynamics", 1.0, p, Q_STATES, QD_STATES, {"theta": 0.1})


def test_lateral_forces_match_the_3d_derivation():
    """The numpy term against Kane's method on the 3-D positions (symbolic.derive_lateral)."""
    import sympy as sp

    from euc_sim.model.symbolic import derive_lateral

    syms, Q_sym = derive_lateral()
    f = sp.lambdify(syms, list(Q_sym), "numpy")
    rng = np.random.default_rng(11)
    lat = _lateral_inputs(20, rng)
    for params in (p, p.replace(h=0.9, l0=0.2, h0=0.3)):
        Q = E.lateral_forces(params, Q_STATES, QD_STATES, **lat)
        args = [getattr(params, k) for k in "R m m0 mw J Jw J0 h0 l0 h g".split()] + [1.0]   # isotropic rider
        states = (Q_STATES[:, 1], Q_STATES[:, 2], QD_STATES[:, 0], QD_STATES[:, 1],
                  QD_STATES[:, 2], lat["theta"], lat["theta_d"], lat["psi_d"], lat["psi_dd"])
        ref = np.array(f(*args, *states)).T
        np.testing.assert_allclose(Q, ref, rtol=1e-10, atol=1e-9)
        assert np.max(np.abs(ref)) > 10.0          # not a comparison of zeros
        # the slender rider (yaw inertia k J, the 3-D model's) differs in the φ row alone,
        # by −upright_slender_moment (the diagnosis's alternative for the interval)
        slender = np.array(f(*args[:-1], E.RIDER_YAW_INERTIA_RATIO, *states)).T
        M_z = E.upright_slender_moment(params, Q_STATES[:, 2], lat["theta"], lat["theta_d"], lat["psi_d"])
        np.testing.assert_allclose(slender[:, :2], ref[:, :2], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(slender[:, 2] - ref[:, 2], -M_z, rtol=1e-10, atol=1e-9)
        assert np.max(np.abs(M_z)) > 1e-2


def test_fast_coordinated_turn_feels_g_over_cos_tilt():
    """ẋ → ∞ with ẋψ̇ = g tan ϑ: only the plane's gravity g/cos ϑ is left (a closed form)."""
    theta = 0.3
    speed = 1e5
    qd = QD_STATES.copy()
    qd[:, 0] = speed
    qd[:, 1:] = 0.0
    # a left turn (ψ̇ > 0) leans the rider left: ϑ = −0.3 rad in CONTRACT's sign (eq. 2)
    Q = E.lateral_forces(p, Q_STATES, qd, -theta, 0.0, p.g * np.tan(theta) / speed, 0.0)
    expected = (1.0 / np.cos(theta) - 1.0) * A.gravity_forces(p, Q_STATES)
    np.testing.assert_allclose(Q, expected, rtol=1e-6, atol=1e-6)


def test_yaw_acceleration_pushes_an_inward_leaning_rider_forward():
    """ψ̈ > 0 (turning left ever faster) with the rider leaning left (ϑ < 0, eq. 2): the
    centre of gravity, inward of P, is dragged backwards in the turning frame, so the
    d'Alembert force tips the upright rider forward."""
    q = np.zeros(3)
    Q = E.lateral_forces(p, q, np.zeros(3), -0.2, 0.0, 0.0, 1.0)
    z_G = p.R - p.l0 + p.h
    expected = (p.J + p.m * p.h * z_G) * np.sin(0.2)
    assert Q[2] == pytest.approx(expected, rel=1e-12)


def test_parameter_and_measurement_effects_have_no_force():
    for name in ("rider_mass", "cog_height_drift", "sensor_time_offset"):
        with pytest.raises(ValueError, match="has no generalised force"):
            E.generalized_force(name, 1.0, p, Q_STATES, QD_STATES)
    heavy = E.apply_to_params(p, "rider_mass", 90.0)
    assert heavy.m == 90.0 and heavy.J == pytest.approx(p.J * 90 / 65)


def test_visibility_follows_the_physics():
    visible = {n for n in E.names() if E.get(n).kinematic_visible}
    assert visible == {"rolling_resistance", "aerodynamic_drag", "road_slope", "sensor_time_offset",
                       "cog_height_drift", "lateral_dynamics"}
    assert E.get("rider_mass").needs == ("M_d",) and E.get("rider_mass").hidden_because


def test_cog_height():
    h = drift.cog_height(0.6, 0.1, np.linspace(0, 12, 1201))
    assert h.max() - h.min() == pytest.approx(0.1, rel=1e-3)
