"""Injected effects act as physics, the same in both engines, with CONTRACT's units."""

import numpy as np

from euc_sim.simulation import drift
import pytest

from euc_sim.simulation import effects as fx
from euc_sim.simulation.mocap import motion_capture
from euc_sim.model.parameters import TABLE3
from euc_sim.simulation.engine import simulate, true_params
from euc_sim.simulation.maneuvers import make_maneuver

#: Speed changes from the start, so every state-dependent force is exercised at once.
MOVING = make_maneuver("acceleration", v0=1.5, v1=3.0, start=0.0, ramp=1.5)
VALUES = {"rolling_resistance": 0.03, "aerodynamic_drag": 0.5, "road_slope": 0.04,
          "wheel_bearing_friction": 2.0, "rider_mass": 85.0, "cog_height_drift": 0.2,
          "lateral_dynamics": 0.25}


def test_every_catalog_effect_is_simulated():
    assert set(VALUES) | {"sensor_time_offset"} == set(fx.names())   # the recording's own: tests/simulation/test_simulation.py


@pytest.mark.parametrize("name", sorted(VALUES))
def test_engines_agree_with_the_effect(name):
    eff = {name: VALUES[name]}
    mj = simulate(MOVING, 1.0, effects=eff)
    an = simulate(MOVING, 1.0, effects=eff, engine="analytic")
    nominal = simulate(MOVING, 1.0)
    diff = np.max(np.abs(mj[["gamma", "phi"]].to_numpy() - an[["gamma", "phi"]].to_numpy()))
    change = np.max(np.abs(mj[["gamma", "phi"]].to_numpy() - nominal[["gamma", "phi"]].to_numpy()))
    assert diff < 1e-7
    assert change > 1000 * diff          # the effect does something, far above the engines' gap


def _steady_motor_torque(eff, v=3.0):
    # the rider's speed integral settles with a 3 s time constant: wait for it
    run = simulate(make_maneuver("constant_speed", v=v), 25.0, effects=eff)
    tail = run[run.t > 23.0]
    return tail.M_d.mean(), tail.x_dot.mean(), run


@pytest.mark.parametrize("name, value, expected", [
    # at steady speed the motor torque balances the external force at the contact:
    # row 1 of eq. (5) with Q_e: M_d = −R Q_e,x
    ("rolling_resistance", 0.02, lambda p, v: 0.02 * p.total_mass * p.g * p.R),
    ("aerodynamic_drag", 0.5, lambda p, v: 0.5 * v * v * p.R),
    ("road_slope", 0.03, lambda p, v: np.sin(0.03) * p.total_mass * p.g * p.R),
    # bearing friction is internal: the motor supplies b ω to the wheel, ω = v/R
    ("wheel_bearing_friction", 2.0, lambda p, v: 2.0 * v / p.R),
])
def test_steady_state_motor_torque_balances_the_effect(name, value, expected):
    M_d, v, _ = _steady_motor_torque({name: value})
    assert M_d == pytest.approx(expected(TABLE3, v), rel=0.01)


def test_no_effect_no_steady_motor_torque():
    M0, v, _ = _steady_motor_torque({})
    assert abs(M0) < 1e-6 and v == pytest.approx(3.0)


@pytest.mark.parametrize("eff", [{"road_slope": 0.03}, {"rolling_resistance": 0.02},
                                 {"aerodynamic_drag": 0.5}])
def test_rider_holds_the_planned_speed_against_steady_forces(eff):
    run = simulate(make_maneuver("constant_speed", v=3.0), 15.0, effects=eff)
    assert abs(run.x_dot.iloc[-1] - 3.0) < 0.02              # integral action of the rider


def test_rolling_resistance_as_mujoco_rolling_friction_on_contact():
    eff = {"rolling_resistance": 0.02}
    moment = simulate("constant_speed", 25.0, variant="contact", effects=eff)
    rolling = simulate("constant_speed", 25.0, variant="contact", effects=eff, rolling_model="contact")
    expected = 0.02 * TABLE3.total_mass * TABLE3.g * TABLE3.R
    assert rolling.M_d.iloc[-2000:].mean() == pytest.approx(expected, rel=0.01)
    assert np.max(np.abs(rolling.phi - moment.phi)) < 1e-3


def test_rider_mass_changes_the_physics_not_the_rider_model():
    run = simulate("constant_speed", 1.0, effects={"rider_mass": 90.0})
    assert run.attrs["true_params"]["m"] == 90.0
    assert run.attrs["true_params"]["J"] == pytest.approx(16.6 * 90 / 65)
    assert run.attrs["params"]["m"] == 65.0
    assert true_params(TABLE3, {"rider_mass": 90.0}).m == 90.0


def test_cog_height_drift_moves_g():
    run = simulate("constant_speed", 6.0, effects={"cog_height_drift": 0.2})
    np.testing.assert_allclose(run.h, drift.cog_height(0.6, 0.2, run.t))
    rec = motion_capture(run, TABLE3, noise="none")
    height = np.hypot(rec.G_X - rec.C_X + 0.05 * np.sin(rec.gamma), rec.G_Z - rec.C_Z + 0.05 * np.cos(rec.gamma))
    np.testing.assert_allclose(height, drift.cog_height(0.6, 0.2, rec.t), atol=1e-9)


def test_lateral_dynamics_tilts_and_turns():
    run = simulate("constant_speed", 6.0, effects={"lateral_dynamics": 0.2})
    assert run.theta.abs().max() == pytest.approx(0.2, rel=1e-3)
    rec = motion_capture(run, TABLE3, noise="none")
    assert rec.C_Y.abs().max() > 0.1 and rec.psi.abs().max() > 0.05
    # the slalom's yaw acceleration acts on the inward-leaning rider: he pitches
    assert run.phi.abs().max() > 1e-3
    turning = simulate(MOVING, 3.0, effects={"lateral_dynamics": 0.2})
    straight = simulate(MOVING, 3.0)
    assert np.max(np.abs(turning.phi - straight.phi)) > 1e-3


def test_lateral_dynamics_obeys_the_equations_it_was_given():
    """The simulated motion satisfies eq. (5) plus effects.lateral_forces, not eq. (5) alone."""
    from euc_sim.model import analytic
    from euc_sim.simulation.maneuvers import lateral_profile

    run = simulate(MOVING, 4.0, effects={"lateral_dynamics": 0.3})
    t = run.t.to_numpy()
    q = run[["x", "gamma", "phi"]].to_numpy()
    qd = run[["x_dot", "gamma_dot", "phi_dot"]].to_numpy()
    qdd = np.gradient(qd, t, axis=0)
    lat = lateral_profile(0.3, t, run.v_ref.to_numpy())
    Q_lat = fx.lateral_forces(TABLE3, q, qd, lat.theta, lat.theta_d, lat.psi_d, lat.psi_dd)
    lhs = (np.einsum("nij,nj->ni", analytic.mass_matrix(TABLE3, q), qdd)
           + analytic.nonlinear_terms(TABLE3, q, qd) - analytic.gravity_forces(TABLE3, q))
    # the motor and ankle cancel from the moment about P (NOTES fact 1)
    inner = slice(50, -50)
    with_lat = analytic.moment_about_contact(TABLE3, lhs - Q_lat)[inner]
    without = analytic.moment_about_contact(TABLE3, lhs)[inner]
    assert np.sqrt(np.mean(without ** 2)) > 5.0
    assert np.sqrt(np.mean(with_lat ** 2)) < 0.01 * np.sqrt(np.mean(without ** 2))


@pytest.mark.parametrize("eff, match", [
    ({"rolling_resistance": -0.01}, r"rolling_resistance: expected a value in \[0, 0\.2\], got -0\.01"),
    ({"rider_mass": 0.0}, r"rider_mass: expected a value in \[30, 200\] kg, got 0\.0"),
    ({"sensor_time_offset": 1e6}, r"sensor_time_offset: expected a value in \[0, 0\.3\] s"),
    ({"road_slope": float("nan")}, "must be finite"),
])
def test_bad_effect_values(eff, match):
    with pytest.raises(ValueError, match=match):
        simulate("constant_speed", 1.0, effects=eff)


def test_a_given_lateral_motion_replaces_the_slalom():
    from euc_sim.simulation.errors import SimulationError
    from euc_sim.simulation.maneuvers import lateral_profile

    run = simulate(MOVING, 2.0, effects={"lateral_dynamics": 0.2})
    motion = lateral_profile(0.2, run.t.to_numpy(), run.v_ref.to_numpy())
    same = simulate(MOVING, 2.0, effects={"lateral_dynamics": 0.2}, lateral_motion=motion)
    np.testing.assert_array_equal(same.phi, run.phi)
    # the value is an effective peak tilt: twice the tilt is four times the coupling
    stronger = simulate(MOVING, 2.0, effects={"lateral_dynamics": 0.4}, lateral_motion=motion)
    assert np.max(np.abs(stronger.phi - run.phi)) > 1e-3
    with pytest.raises(SimulationError, match="lateral_motion: expected arrays of 2001 samples"):
        simulate(MOVING, 2.0, effects={"lateral_dynamics": 0.2},
                 lateral_motion=lateral_profile(0.2, run.t.to_numpy()[:10], run.v_ref.to_numpy()[:10]))
