"""Controllers: the motor PD, the rider's trim and design, the linearisation."""

import math

import numpy as np
import pytest

from euc_sim.controllers.design import delayed_closed_loop_radius, design_rider
from euc_sim.controllers.plant import linear_plant, predictor_rows, rider_plant
from euc_sim.controllers.motor import MotorError, MotorPD
from euc_sim.controllers.rider import Rider, RiderError, motor_noise, trim
from euc_sim.model import analytic
from euc_sim.model.linearize import check_against_mujoco, delay_margin, discretize, jacobians, numeric_jacobians
from euc_sim.simulation.stability import stability_report
from euc_sim.model.parameters import TABLE3


def test_motor_is_pd_inside_the_limit_and_saturates():
    m = MotorPD(Kp=600.0, Kd=40.0, torque_limit=100.0)
    assert m.torque(0.01, -0.2) == pytest.approx(600 * 0.01 + 40 * -0.2)
    assert m.torque(0.5, 0.0) == 100.0
    assert m.torque(-0.5, 0.0) == -100.0


def test_tiltback_sets_the_pitch_back_above_its_speed():
    m = MotorPD(tiltback_speed=5.0, tiltback_gain=0.04)
    assert m.gamma_ref(4.9) == 0.0
    assert m.gamma_ref(6.0) == pytest.approx(-0.04)
    assert m.gamma_ref(-6.0) == pytest.approx(0.04)
    # at 6 m/s an upright body already gets a forward-driving torque: the set-point is behind
    assert m.torque(0.0, 0.0, 6.0) == pytest.approx(600 * 0.04)


@pytest.mark.parametrize("kw, match", [
    ({"Kp": -1.0}, "'Kp' must be a finite non-negative"),
    ({"Kd": math.nan}, "'Kd' must be a finite"),
    ({"torque_limit": 0.0}, "torque_limit must be positive"),
    ({"tiltback_speed": 0.0}, "tiltback_speed must be positive"),
])
def test_motor_rejects_bad_settings(kw, match):
    with pytest.raises(MotorError, match=match):
        MotorPD(**kw)


@pytest.mark.parametrize("kw, match", [
    ({"K": (1.0, 2.0)}, "5 or 6 finite numbers"),
    ({"delay": -0.1}, "'delay' must be finite and non-negative"),
    ({"noise_tau": 0.0}, "'noise_tau' must be positive"),
])
def test_rider_rejects_bad_settings(kw, match):
    with pytest.raises(RiderError, match=match):
        Rider(**kw)


@pytest.mark.parametrize("a", [-2.0, -0.7, 0.0, 0.4, 1.5])
def test_trim_is_a_steady_acceleration_of_eq5(a):
    motor = MotorPD()
    gamma, phi, M_d, M_h = trim(TABLE3, motor, a)
    assert M_d == pytest.approx(motor.torque(float(gamma), 0.0))
    qdd = analytic.forward_dynamics(TABLE3, np.array([0.0, gamma, phi]), np.zeros(3), M_d, M_h)
    np.testing.assert_allclose(qdd, [a, 0.0, 0.0], atol=1e-10)


def test_trim_leans_back_to_slow_down():
    gamma, phi, M_d, M_h = trim(TABLE3, MotorPD(), -1.0)
    assert phi < -0.05 and gamma < 0 and M_d < 0


def test_motor_noise_is_seeded_and_has_its_std():
    a = motor_noise(20000, 1e-3, 3.0, 0.05, seed=4)
    b = motor_noise(20000, 1e-3, 3.0, 0.05, seed=4)
    c = motor_noise(20000, 1e-3, 3.0, 0.05, seed=5)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert 2.4 < a.std() < 3.6
    assert not motor_noise(10, 1e-3, 0.0, 0.05, seed=1).any()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_analytic_jacobians_match_central_differences(seed):
    rng = np.random.default_rng(seed)
    y = rng.normal(0, [1, 0.5, 0.5, 2, 2, 2])
    u = rng.normal(0, 20, 2)
    A, B = jacobians(TABLE3, y, *u)
    An, Bn = numeric_jacobians(TABLE3, y, *u)
    np.testing.assert_allclose(A, An, atol=1e-6)
    np.testing.assert_allclose(B, Bn, atol=1e-8)


def test_analytic_jacobians_match_mujoco_transition_fd():
    r = check_against_mujoco(TABLE3)
    assert r["relative_error"] < 1e-4, r


def test_delay_margin_of_a_first_order_loop():
    # L(s) = 2 / (s + 1): crossover at √3 rad/s, phase −π/3, margin (π − π/3)/√3
    tau, wc = delay_margin(np.array([[-1.0]]), np.array([[1.0]]), np.array([[2.0]]))
    assert wc == pytest.approx(math.sqrt(3), rel=1e-6)
    assert tau == pytest.approx(2 * math.pi / (3 * math.sqrt(3)), rel=1e-6)


def test_lqr_rider_stabilises_the_linear_loop():
    A, B = linear_plant(TABLE3, MotorPD())
    assert np.max(np.linalg.eigvals(A).real) > 1.0          # the rider alone falls
    r = design_rider(scales={"x_int": None})                 # without integral action
    assert len(r.K) == 5
    assert np.max(np.linalg.eigvals(A - B @ np.array(r.K)[None]).real) < -0.5
    r = design_rider()                                       # with it (the default)
    Aa, Ba = rider_plant(TABLE3, MotorPD())
    assert len(r.K) == 6 and Aa.shape == (6, 6)
    assert np.max(np.linalg.eigvals(Aa - Ba @ np.array(r.K)[None]).real) < -0.1


def test_reaction_delay_needs_the_predictor():
    r = design_rider()
    assert delayed_closed_loop_radius(rider=r) < 1.0
    assert delayed_closed_loop_radius(rider=r.replace(predictor=False)) > 1.0


def test_predictor_rows_predict_the_linear_state():
    p, motor, dt, n = TABLE3, MotorPD(), 1e-3, 50
    A, B = rider_plant(p, motor)
    Phi, Gam = discretize(A, B, dt)
    K = np.array(design_rider().K)
    KPn, KG = predictor_rows(p, motor, K, dt, n)
    rng = np.random.default_rng(0)
    s = rng.normal(0, 0.05, 6)
    s0 = s.copy()
    u = rng.normal(0, 5.0, n)
    for i in range(n):
        s = Phi @ s + Gam[:, 0] * u[i]
    assert KPn @ s0 + KG @ u == pytest.approx(K @ s, rel=1e-9)


def test_stability_report_is_stable_with_delay():
    rep = stability_report(check_mujoco=False)
    assert rep["max_real_part"]["open_loop"] > 0
    assert rep["max_real_part"]["motor_pd_and_rider"] < 0
    assert rep["rider_loop"]["stable_with_delay"] is True
    assert rep["jacobian_check"]["analytic_vs_central_difference"] < 1e-5


def test_stability_cli_writes_json(tmp_path, capsys):
    import json

    from euc_sim.cli import main
    out = tmp_path / "s.json"
    assert main(["stability", "--json", str(out)]) == 0
    rep = json.loads(out.read_text())
    assert rep["ok"] is True
    lo, hi = rep["rider_loop"]["tolerated_actual_delay"]
    assert lo < 0.15 < hi
    assert rep["jacobian_check"]["analytic_vs_mjd_transitionFD"]["relative_error"] < 1e-4
    assert "delay margin" in capsys.readouterr().out


def test_stability_cli_bad_output(tmp_path, capsys):
    from euc_sim.cli import main
    (tmp_path / "f").write_text("")
    assert main(["stability", "--json", str(tmp_path / "f" / "s.json")]) == 2
    assert "cannot write" in capsys.readouterr().err


def _rider_runs(limit=400.0, integral=False):
    import numpy as np

    from euc_sim.controllers.rider import RiderRun
    from euc_sim.simulation.engine import default_rider
    from euc_sim.simulation.maneuvers import as_maneuver

    t = np.arange(3001) * 1e-3
    v, a = as_maneuver("stop_and_go").reference(t)
    rider = default_rider(TABLE3, MotorPD(), noise_std=3.0).replace(torque_limit=limit)
    K = tuple(rider.K[:5]) + ((5.0,) if integral else ())
    rider = rider.replace(K=K)
    return (RiderRun(rider, TABLE3, MotorPD(), v, a, 1e-3, 1), RiderRun(rider, TABLE3, MotorPD(), v, a, 1e-3, 1))


@pytest.mark.parametrize("limit, integral", [(400.0, False), (400.0, True), (60.0, True)])
def test_rider_commands_in_blocks_equal_the_step_by_step_law(limit, integral):
    """commands() solves the predictor's recursion for n + 1 steps at once; it must give
    command()'s torques (to round-off), also where the torque limit binds (60 N·m)."""
    import numpy as np

    one, blocks = _rider_runs(limit, integral)
    n = one.n
    rng = np.random.default_rng(4)
    Y = rng.normal(size=(3001 + n, 6)) * [0.0, 0.02, 0.05, 0.3, 0.2, 0.3]
    stepwise = np.array([one.command(k, Y) for k in range(3001)])
    blocked = np.vstack([np.column_stack(blocks.commands(k0, Y[k0:min(k0 + n + 1, 3001)]))
                         for k0 in range(0, 3001, n + 1)])
    np.testing.assert_allclose(blocked, stepwise, rtol=0, atol=1e-9 * np.max(np.abs(stepwise)))
    assert (np.max(np.abs(stepwise[:, 0])) == limit) == (limit == 60.0)      # the limit binds at 60 N·m only
    with pytest.raises(ValueError, match="at most n \\+ 1 = 151 steps, got 152"):
        blocks.commands(0, Y[:152])
