"""The duty model's extra terms (euc_sim.rides.drive.pwm): dead time and flux weakening, kept only
when held-out validation asks for them, and the force left at full duty."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.controllers.motor import MotorError, MotorPD
from euc_sim.rides.drive.cutout import DutyModel, OcvLine, full_duty_accel
from euc_sim.rides.drive.pwm import BASE, back_emf, pwm_columns, select_pwm_terms

TRUE = {"K_v": 7.4, "r_F": 0.03, "dead_time": 0.03, "flux_weakening": 0.09}


def _ride(coef, seed=0, n=6000, noise=0.5):
    """Speed, force, voltage and the duty the model gives, with 0.5 V of noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.1
    v = 11.0 + 8.0 * np.sin(2 * np.pi * t / 170.0) + rng.normal(0, 0.3, n)
    F = 150.0 * np.sin(2 * np.pi * t / 23.0) + 60.0 + rng.normal(0, 20.0, n)
    V = 150.0 - 10.0 * t / t[-1] - 0.05 * F
    names = [k for k in BASE + ("dead_time", "flux_weakening") if k in coef]
    volts = pwm_columns(v, F, V, names) @ np.array([coef[k] for k in names])
    return v, F, V, (volts + rng.normal(0, noise, n)) / V, t


def test_both_terms_kept_and_recovered():
    v, F, V, d, t = _ride(TRUE)
    names, history = select_pwm_terms(v, F, V, d, t)
    assert set(names) == set(TRUE)
    assert history[0]["heldout_rmse"] > 5 * history[-1]["heldout_rmse"]
    beta = np.linalg.lstsq(pwm_columns(v, F, V, names), d * V, rcond=None)[0]
    for name, b in zip(names, beta):
        assert b == pytest.approx(TRUE[name], rel=0.02), name


def test_a_plain_dc_motor_keeps_neither():
    v, F, V, d, t = _ride({"K_v": 7.4, "r_F": 0.03}, seed=1)
    names, history = select_pwm_terms(v, F, V, d, t)
    assert names == list(BASE) and len(history) == 1


def _force_left(coef, speed, volts):
    """The wheel force, N, the duty model leaves at ``speed`` (m/s) without sag, losses or road load
    (:func:`euc_sim.rides.drive.cutout.full_duty_accel` on a 1 kg wheel); 0 where none is left."""
    m = DutyModel(pwm=coef, R_int=0.0, ocv=OcvLine(volts, 0.0, "x"), m_eq=1.0, mass=1.0)
    return np.nan_to_num(full_duty_accel(m, np.asarray(speed, float), volts, iterations=80))


def test_no_force_is_left_where_the_back_emf_takes_the_whole_duty():
    """7 V/(m/s) against 140 V: none left from 20 m/s; with 3 % dead time, from 140·0.97/7 = 19.4 m/s."""
    assert _force_left({"K_v": 7.0, "r_F": 0.03}, [19.99, 20.01], 140.0).tolist() == [
        pytest.approx(0.01 * 7.0 / 0.03, rel=1e-6), 0.0]
    assert _force_left({"K_v": 7.0, "r_F": 0.03, "dead_time": 0.03}, [19.41], 140.0)[0] == 0.0


def test_flux_weakening_is_not_extrapolated_past_the_fitted_speeds():
    coef = dict(TRUE, v_fw=10.0)
    e = back_emf(coef, np.array([5.0, 10.0, 20.0]))
    K, c = TRUE["K_v"], TRUE["flux_weakening"]
    np.testing.assert_allclose(e, [K * 5 - c * 25, K * 10 - c * 100, K * 20 - c * 200])
    cols = pwm_columns(np.array([20.0]), np.array([0.0]), np.array([1.0]), ["flux_weakening"], 10.0)
    assert cols[0, 0] == -200.0


def test_the_simulators_motor_has_the_same_limit():
    coef, R = dict(TRUE, v_fw=12.0), 0.2
    motor = MotorPD(voltage=140.0, back_emf=coef["K_v"], drop=coef["r_F"] / R,
                    dead_time=coef["dead_time"], flux_weakening=coef["flux_weakening"],
                    fw_speed=coef["v_fw"])
    for v in (2.0, 6.0, 12.0, 18.0):       # the duty model is fitted from 2 m/s up
        assert motor.voltage_torque(v) == pytest.approx(_force_left(coef, [v], 140.0)[0] * R, rel=1e-12)
    assert "fw_speed" not in MotorPD().as_dict() and motor.as_dict()["fw_speed"] == 12.0
    with pytest.raises(MotorError, match="dead_time"):
        MotorPD(voltage=140.0, drop=0.1, dead_time=1.5)
