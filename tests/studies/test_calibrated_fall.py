"""studies/calibrated_fall.py: its pure helpers and its bad-input exits (the window itself is a study)."""

import sys

import numpy as np
import pytest

import calibrated_fall


def test_distance_ahead_integrates_the_speed_error():
    t = np.linspace(0.0, 10.0, 1001)
    d = calibrated_fall.distance_ahead(t, 2.0 + 0.5 * t, np.full(t.size, 2.0))   # ẋ − v_ref = 0.5 t
    np.testing.assert_allclose(d, 0.25 * t ** 2, atol=1e-9)
    assert calibrated_fall.distance_ahead([0.0], [1.0], [0.0]).tolist() == [0.0]


def test_missing_input_exits_2(tmp_path, capsys):
    assert calibrated_fall.main([str(tmp_path), str(tmp_path / "h.csv"), str(tmp_path / "s.csv")]) == 2
    err = capsys.readouterr().err
    assert "ride.json" in err and len(err.strip().splitlines()) == 1


def test_unknown_variant_exits_2(tmp_path, capsys):
    for name in ("ride.json", "h.csv", "s.csv"):
        (tmp_path / name).write_text("{}")
    assert calibrated_fall.main([str(tmp_path), str(tmp_path / "h.csv"), str(tmp_path / "s.csv")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_parametric_variants_are_described_and_bad_ones_refused():
    assert "0.02" in calibrated_fall.describe("rolling_cap=0.02")
    assert "0.3 m/s" in calibrated_fall.describe("rolling_sign=0.3")
    assert calibrated_fall.describe("no_rolling") == calibrated_fall.VARIANTS["no_rolling"]
    for bad in ("rolling_sign=0", "rolling_sign=-1", "rolling_cap=x", "rolling_cap=nan", "seedless"):
        with pytest.raises(ValueError, match="unknown variant"):
            calibrated_fall.describe(bad)


def test_trim_with_rolling_holds_the_rolling_moment():
    from euc_sim.controllers.motor import MotorPD
    from euc_sim.controllers.rider import trim
    from euc_sim.model.parameters import TABLE3 as p

    motor, C_rr, a, v = MotorPD(), 0.03, 0.4, 3.0
    base = trim(p, motor, a, v)
    with_rr = calibrated_fall.trim_with_rolling(C_rr, 0.01)(p, motor, a, v)
    # eq. (5) row 1 gains the rolling moment C_rr N R (v far above the 0.01 m/s regularisation)
    np.testing.assert_allclose(with_rr[2] - base[2], C_rr * p.total_mass * p.g * p.R, rtol=1e-9)
    # row 3 with the actual acceleration: m h (g sin φ − a cos φ) = M_h
    phi, M_h = float(with_rr[1]), float(with_rr[3])
    np.testing.assert_allclose(p.m * p.h * (p.g * np.sin(phi) - a * np.cos(phi)), M_h, rtol=1e-9)
    assert with_rr[1] > base[1]                      # he leans further to hold the motor's reaction
    # at rest, or without rolling resistance, it is the trim
    for got, want in zip(calibrated_fall.trim_with_rolling(C_rr, 0.01)(p, motor, a, 0.0), trim(p, motor, a, 0.0)):
        np.testing.assert_allclose(got, want, rtol=1e-12)
    for got, want in zip(calibrated_fall.trim_with_rolling(0.0, 0.01)(p, motor, a, v), base):
        np.testing.assert_allclose(got, want, rtol=1e-12)


def test_swapped_restores_the_attribute():
    import types

    mod = types.SimpleNamespace(SIGN_SPEED=0.01)
    with calibrated_fall._swapped(mod, "SIGN_SPEED", 0.1):
        assert mod.SIGN_SPEED == 0.1
    assert mod.SIGN_SPEED == 0.01
