"""What differs between two rides: intervals, the held-out gate, aliases, the adapter, the sentence."""

import math

import numpy as np
import pytest

from euc_sim.rides import differences as df
from euc_sim.rides.power import RHO_AIR


def _ride(seed, n=4000):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.1
    v = 8.0 + 4.0 * np.sin(2 * np.pi * t / 50.0) + 2.0 * np.sin(2 * np.pi * t / 170.0)
    av = v * np.gradient(v, t)
    P = 90.0 * av + 20.0 * v + 0.3 * v ** 3 + 5.0 * rng.standard_normal(n)
    return t, v, av, P


def test_difference_interval_of_two_symmetric_intervals():
    d, (lo, hi) = df.difference_interval(1.0, (0.7, 1.3), 1.5, (1.1, 1.9))
    assert d == pytest.approx(0.5)
    assert hi - d == pytest.approx(math.hypot(0.3, 0.4))
    assert d - lo == pytest.approx(math.hypot(0.3, 0.4))


def test_ratio_interval_in_logarithms():
    r, (lo, hi) = df.difference_interval(1.0, (0.99, 1.01), 0.95, (0.94, 0.96), ratio=True)
    assert r == pytest.approx(-0.05)
    assert lo < r < hi < 0


def test_heldout_gain_sees_a_signature_and_not_noise():
    t, v, av, P = _ride(0)
    rng = np.random.default_rng(1)
    noise = 5.0 * rng.standard_normal(len(t))
    assert df.heldout_gain(t, noise + 0.15 * v ** 3, v ** 3) > 0.3
    assert df.heldout_gain(t, noise, v ** 3) < df.MIN_GAIN


def test_residual_coefficient_recovers_the_hidden_drag():
    t, v, av, P = _ride(0)
    rng = np.random.default_rng(2)
    est, (lo, hi) = df.residual_coefficient(t, 0.15 * v ** 3 + 5.0 * rng.standard_normal(len(t)), v ** 3)
    assert lo < 0.15 < hi
    assert est == pytest.approx(0.15, rel=0.05)


def test_aliases_drag_and_rolling_on_a_steady_ride_not_mass():
    t = np.arange(3000) * 0.1
    v = 10.0 + 0.5 * np.sin(2 * np.pi * t / 40.0)
    av = v * np.gradient(v, t)
    cols = df.signature_columns(v, av, 100.0 * v, t, coef={"total_mass": 100.0})
    aliases, cannot = df.alias_table(cols)
    assert "rolling_resistance" in aliases["aerodynamic_drag"]
    assert "aerodynamic_drag" not in aliases["total_mass"]
    assert not cannot


def test_constant_signature_cannot_be_seen():
    t = np.arange(500) * 0.1
    v = np.full_like(t, 8.0)
    cols = df.signature_columns(v, np.zeros_like(t), 100.0 * v, t)
    _, cannot = df.alias_table(cols)
    assert "total_mass" in cannot


def _params(mass, cdA, crr, R, scale, w=0.02):
    return df.parameters_from_ride({
        "total_mass": {"estimate": mass, "ci95": [mass - 20, mass + 20],
                       "statistical_ci95": [mass - 5, mass + 5], "lag_s": 0.0},
        "drivetrain": {"C_dA": {"estimate": cdA, "ci95": [cdA - 0.05, cdA + 0.05], "unit": "m^2"},
                       "C_rr": {"estimate": crr, "ci95": [crr - 0.002, crr + 0.002], "unit": "dimensionless"},
                       "internal_resistance": {"estimate": R, "ci95": [R - 0.01, R + 0.01], "unit": "ohm"},
                       "speed_scale": {"estimate": scale, "ci95": [scale - w, scale + w], "unit": "dimensionless"},
                       "ocv_start": {"estimate": 84.0, "ci95": [83.9, 84.1], "unit": "V"}}})


def test_adapter_maps_names_and_drag_area_to_k():
    p = {x["name"]: x for x in _params(100.0, 0.5, 0.01, 0.2, 1.0)}
    assert p["aerodynamic_drag"]["estimate"] == pytest.approx(0.5 * RHO_AIR * 0.5)
    assert p["aerodynamic_drag"]["unit"] == "kg/m"
    assert p["total_mass"]["ci95"] == [95.0, 105.0]          # statistical part
    assert p["current_delay"]["ci95"] is None
    assert {"rolling_resistance", "internal_resistance", "speed_scale", "ocv_start"} <= set(p)
    own = [{"name": "x", "estimate": 1.0, "ci95": [0, 2], "unit": "1"}]
    assert df.parameters_from_ride({"parameters": own}) == own


def _gains(**kw):
    g = {n: 0.0 for n in df.PHYSICS}
    g.update(kw)
    return g


def test_drag_named_alone_and_said_in_a_riders_words():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.8, 0.01, 0.2, 1.0)
    res = df.ride_differences(a, b, _gains(aerodynamic_drag=0.2), {}, {}, "the 16 May ride")
    named = [d.name for d in res.items if d.named]
    assert named == ["aerodynamic_drag"]
    drag = next(d for d in res.items if d.name == "aerodynamic_drag")
    assert drag.estimate == pytest.approx(0.5 * RHO_AIR * 0.3)
    assert "0.18 kg/m more drag" in res.sentence and "16 May" in res.sentence
    js = res.to_json()
    assert {"name", "estimate", "ci95", "unit", "named", "why"} <= set(js["differences"][0])


def test_interval_alone_does_not_name_without_heldout_gain():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.8, 0.01, 0.2, 1.0)
    res = df.ride_differences(a, b, _gains(), {}, {}, "x")
    assert not any(d.named for d in res.items)
    assert "nothing" in res.sentence


def test_state_of_charge_never_named():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.5, 0.01, 0.2, 1.0)
    b = [dict(p, estimate=80.0, ci95=[79.9, 80.1]) if p["name"] == "ocv_start" else p for p in b]
    res = df.ride_differences(a, b, _gains(), {}, {}, "x")
    ocv = next(d for d in res.items if d.name == "ocv_start")
    assert ocv.estimate == pytest.approx(-4.0) and not ocv.named


def test_of_two_aliased_named_the_larger_gain_wins():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.8, 0.02, 0.2, 1.0)
    al = {"aerodynamic_drag": ["rolling_resistance"], "rolling_resistance": ["aerodynamic_drag"]}
    res = df.ride_differences(a, b, _gains(aerodynamic_drag=0.2, rolling_resistance=0.1), al, {}, "x")
    named = [d.name for d in res.items if d.named]
    assert named == ["aerodynamic_drag"]
    roll = next(d for d in res.items if d.name == "rolling_resistance")
    assert "aerodynamic_drag explains more" in roll.why


def test_speed_scale_is_a_ratio_minus_one():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0, 0.005), _params(100.0, 0.5, 0.01, 0.2, 1 / 1.05, 0.005)
    res = df.ride_differences(a, b, _gains(speed_scale=0.3), {}, {}, "x")
    s = next(d for d in res.items if d.name == "speed_scale")
    assert s.estimate == pytest.approx(1 / 1.05 - 1) and s.named and s.unit == "1"


def test_mass_entry_is_the_mass_difference_view():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(130.0, 0.5, 0.01, 0.2, 1.0)
    view = {"estimate": 29.0, "ci95": [10.0, 48.0], "unit": "kg"}
    res = df.ride_differences(a, b, _gains(total_mass=0.1), {}, {}, "x", mass_view=view)
    m = next(d for d in res.items if d.name == "total_mass")
    assert m.estimate == pytest.approx(29.0) and m.ci95 == pytest.approx((10.0, 48.0)) and m.named


def test_no_balance_on_log_gives_no_test():
    from types import SimpleNamespace

    from euc_sim.rides.differences_report import log_model_residual

    t, v, av, P = _ride(0, n=300)
    sig = SimpleNamespace(t=t, v=v, P=P)
    ok, res = log_model_residual(sig, SimpleNamespace(coef={}, lag=0.0))
    assert not ok.any() and res.size == 0
    assert df.heldout_gain(t[ok], res, v[ok] ** 3) is None
    assert df.residual_coefficient(t[ok], res, v[ok] ** 3) is None
