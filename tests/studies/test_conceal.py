"""Concealed effects in a synthetic EUC World log: the physics term, nothing else, no mutation."""

import numpy as np
import pandas as pd
import pytest
import conceal as cc

from euc_sim.rides.grids.power import G, RHO_AIR


def _raw(n=3000, seed=0, R=0.15):
    """A synthetic EUC World table: speed waves, a hill, a pack with sag R, phase current and margin."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.2
    v = 8.0 + 4.0 * np.sin(2 * np.pi * t / 60.0) + 0.05 * rng.standard_normal(n)
    alt = 100.0 + 5.0 * np.sin(2 * np.pi * t / 300.0)
    F = 20.0 + 0.3 * v ** 2 + 60.0 * np.gradient(v, t)
    P = F * v / 0.85
    E = 84.0 - 0.001 * t
    I = (E - np.sqrt(E * E - 4 * R * P)) / (2 * R)
    V = E - R * I
    duty = (1.1 * v + 0.02 * F) / V
    ts = pd.Timestamp("2025-05-16T10:00:00+02:00") + pd.to_timedelta(t, unit="s")
    return pd.DataFrame({
        "datetime": ts.strftime("%Y-%m-%dT%H:%M:%S.%f+0200"), "speed": v * 3.6,
        "speed_max": np.maximum.accumulate(v * 3.6), "distance": np.cumsum(v * 0.2) / 1000.0,
        "distance_total": 500.0 + np.cumsum(v * 0.2) / 1000.0, "voltage": V, "current": I,
        "current_phase": 0.5 * F, "power": V * I, "safety_margin": 100.0 - 100.0 * duty,
        "gps_alt": alt, "gps_speed": v * 3.6, "extra": [""] * n})


def _moving(raw):
    return raw["speed"].to_numpy() / 3.6 > cc.V_MIN


def test_null_is_an_equal_copy():
    raw = _raw()
    out = cc.conceal(raw, "null", 0.0)
    pd.testing.assert_frame_equal(out, raw)
    assert out is not raw


@pytest.mark.parametrize("effect,size,kw", [
    ("total_mass", 30.0, {}), ("aerodynamic_drag", 0.25, {}), ("rolling_resistance", 0.01, {"total_mass": 100.0}),
    ("internal_resistance", 0.08, {}), ("speed_scale", 1.05, {}), ("current_delay", 0.4, {})])
def test_input_not_mutated(effect, size, kw):
    raw = _raw()
    before = raw.copy()
    out = cc.conceal(raw, effect, size, **kw)
    pd.testing.assert_frame_equal(raw, before)
    assert not out.equals(raw)


def test_zero_sizes_change_nothing_physical():
    raw = _raw()
    for effect, kw in [("total_mass", {}), ("aerodynamic_drag", {}), ("rolling_resistance", {"total_mass": 90.0}),
                       ("internal_resistance", {})]:
        out = cc.conceal(raw, effect, 0.0, **kw)
        for c in ("voltage", "current", "power", "current_phase", "safety_margin"):
            np.testing.assert_allclose(out[c], raw[c], rtol=1e-9, atol=1e-9, err_msg=f"{effect} {c}")


def test_drag_extra_battery_power_is_the_physics_term():
    raw, eta = _raw(), 0.85
    out = cc.conceal_wheel_power(raw, "aerodynamic_drag", 0.25, eta=eta)
    v = raw["speed"].to_numpy() / 3.6
    P0 = (raw["voltage"] * raw["current"]).to_numpy()
    extra = (out["voltage"] * out["current"]).to_numpy() - P0
    term = 0.5 * RHO_AIR * 0.25 * v ** 3
    mot, brk = P0 > 0, P0 * eta + term < 0          # motoring; braking before and after
    assert mot.sum() > 100 and brk.sum() > 10
    np.testing.assert_allclose(extra[mot], term[mot] / eta, rtol=1e-6)
    np.testing.assert_allclose(extra[brk], term[brk] * eta, rtol=1e-6)
    np.testing.assert_allclose(out["power"] - raw["power"], extra, rtol=1e-9)


def test_rolling_extra_battery_power_is_the_physics_term():
    raw = _raw()
    out = cc.conceal_wheel_power(raw, "rolling_resistance", 0.01, eta=0.9, total_mass=100.0)
    v = raw["speed"].to_numpy() / 3.6
    P0 = (raw["voltage"] * raw["current"]).to_numpy()
    extra = (out["voltage"] * out["current"]).to_numpy() - P0
    mot = P0 > 0
    np.testing.assert_allclose(extra[mot], 0.01 * 100.0 * G * v[mot] / 0.9, rtol=1e-6)


def test_voltage_sags_with_the_packs_own_resistance():
    raw = _raw(R=0.15)
    kin = cc.kinematics(raw)
    assert cc.log_constants(raw, kin).R_pack == pytest.approx(0.15, rel=0.05)
    c = cc.log_constants(raw, kin)
    assert c.k_Q == pytest.approx(0.001 * 3600 / np.mean(raw["current"]), rel=0.2)
    out = cc.conceal_wheel_power(raw, "aerodynamic_drag", 0.3)
    dV = (out["voltage"] - raw["voltage"]).to_numpy()
    dI = (out["current"] - raw["current"]).to_numpy()
    # the pack's own sag and the extra charge drawn
    np.testing.assert_allclose(dV, -c.R_pack * dI - c.k_Q * cc.charge_drawn(kin.t, dI), rtol=1e-3, atol=1e-6)


def test_mass_adds_inertia_and_climb_and_phase_current():
    raw = _raw()
    kin = cc.kinematics(raw)
    out = cc.conceal_wheel_power(raw, "total_mass", 30.0, eta=0.85)
    dP_w = 30.0 * (kin.a + G * kin.sin_grade) * kin.v
    P_el = (raw["voltage"] * raw["current"]).to_numpy()
    mot = (P_el > 0) & (P_el * 0.85 + dP_w > 0)
    assert mot.sum() > 100
    extra = (out["voltage"] * out["current"]).to_numpy() - P_el
    np.testing.assert_allclose(extra[mot], dP_w[mot] / 0.85, rtol=1e-6, atol=1e-9)
    m = _moving(raw)
    dF = dP_w[m] / kin.v[m]
    k = cc.log_constants(raw, kin).k_phase
    assert k == pytest.approx(0.5 * 0.85, rel=0.05)
    np.testing.assert_allclose((out["current_phase"] - raw["current_phase"])[m], k * dF, rtol=1e-9)
    assert np.abs(kin.sin_grade[m]).max() > 0.005     # the hill is seen


def test_braking_multiplies_by_efficiency():
    p = np.array([-1000.0, 1000.0])
    np.testing.assert_allclose(cc.electrical_power(p, 0.8), [-800.0, 1250.0])


def test_aged_pack_keeps_power_and_drops_voltage():
    raw = _raw(R=0.1)
    out = cc.conceal_resistance(raw, 0.08)
    np.testing.assert_allclose(out["voltage"] * out["current"], raw["voltage"] * raw["current"], rtol=1e-9)
    loaded = raw["current"].to_numpy() > 5
    assert np.all(out["voltage"].to_numpy()[loaded] < raw["voltage"].to_numpy()[loaded])
    kin = cc.kinematics(raw)
    c = cc.log_constants(raw, kin)
    W = raw["voltage"] + c.R_pack * raw["current"]
    dQ = cc.charge_drawn(kin.t, (out["current"] - raw["current"]).to_numpy())
    np.testing.assert_allclose(out["voltage"], W - c.k_Q * dQ - (c.R_pack + 0.08) * out["current"],
                               rtol=1e-4)
    # the motor's volts d·V unchanged
    d0 = (1 - raw["safety_margin"] / 100) * raw["voltage"]
    d1 = (1 - out["safety_margin"] / 100) * out["voltage"]
    np.testing.assert_allclose(d1, d0, rtol=1e-9)


def test_tyre_size_scales_wheel_channels_not_gps():
    raw = _raw()
    out = cc.conceal_tyre_size(raw, 1.05)
    np.testing.assert_allclose(out["speed"], raw["speed"] * 1.05)
    np.testing.assert_allclose(out["distance"], raw["distance"] * 1.05)
    d0 = raw["distance_total"].iloc[0]
    np.testing.assert_allclose(out["distance_total"] - d0, (raw["distance_total"] - d0) * 1.05,
                               rtol=1e-9, atol=1e-9)
    pd.testing.assert_series_equal(out["gps_speed"], raw["gps_speed"])
    pd.testing.assert_series_equal(out["current"], raw["current"])


def test_current_delay_shifts_current_only():
    raw = _raw()
    out = cc.conceal_current_delay(raw, 0.4)
    # samples every 0.2 s: a 0.4 s delay is two rows
    np.testing.assert_allclose(out["current"].to_numpy()[2:], raw["current"].to_numpy()[:-2], rtol=1e-9)
    pd.testing.assert_series_equal(out["voltage"], raw["voltage"])
    pd.testing.assert_series_equal(out["speed"], raw["speed"])


def test_unknown_effect_and_missing_column_are_named():
    with pytest.raises(ValueError, match="effect 'wind'"):
        cc.conceal(_raw(), "wind", 1.0)


def test_read_raw_names_a_missing_column(tmp_path):
    p = tmp_path / "x.csv"
    pd.DataFrame({"datetime": ["2025-01-01T00:00:00+0000"], "speed": [1.0]}).to_csv(p, index=False)
    with pytest.raises(ValueError, match="'voltage'"):
        cc.read_raw(p)


def test_write_raw_never_overwrites(tmp_path):
    p = tmp_path / "c.csv"
    raw = _raw(n=50)
    cc.write_raw(raw, p)
    with pytest.raises(FileExistsError):
        cc.write_raw(raw, p)
