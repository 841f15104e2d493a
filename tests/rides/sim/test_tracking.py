"""The rider's plan along a logged profile: the band limit from the right-half-plane zero (issue 21)."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.controllers.plant import speed_zero
from euc_sim.model.parameters import TABLE3
from euc_sim.rides.grids.signals import RideAssumptions
from euc_sim.rides.sim.simulate import ride_params
from euc_sim.rides.sim.envelope import limit_acceleration, moving_average, plan_band_limit, rider_acceleration_limit
from euc_sim.rides.sim.tracking import simulate_profile


def test_moving_average_keeps_the_envelope_and_has_no_time_shift():
    t = np.arange(0.0, 30.0, 0.1)
    rng = np.random.default_rng(4)
    v = limit_acceleration(t, 8.0 + np.cumsum(rng.normal(0.0, 0.3, t.size)), 1.4)
    out = moving_average(t, v, 1.8)
    assert np.abs(np.diff(out) / 0.1).max() <= 1.4 + 1e-9           # |a| within the envelope
    sym = np.interp(t, [0, 10, 12, 14, 30], [5, 5, 7, 5, 5])         # symmetric bump at 12 s
    sm = moving_average(t, sym, 1.8)
    assert t[np.argmax(sm)] == pytest.approx(12.0, abs=1e-9)
    assert sm[t < 12.0][::-1][:50] == pytest.approx(sm[t > 12.0][:50], abs=1e-9)
    assert moving_average(t, v, 0.0) == pytest.approx(v)
    with pytest.raises(ValueError, match="width"):
        moving_average(t, v, -1.0)


def test_moving_average_half_power_where_documented():
    dt, width = 0.01, 1.01                                          # 101 samples exactly
    t = np.arange(0.0, 200.0, dt)
    w = 2.7832 / width
    out = moving_average(t, np.sin(w * t), width)
    mid = (t > 20) & (t < 180)
    assert np.abs(out[mid]).max() == pytest.approx(1 / np.sqrt(2), abs=0.01)


def test_plan_band_limit_is_half_the_zero():
    width, z = plan_band_limit(TABLE3)
    assert z == pytest.approx(speed_zero(TABLE3))
    assert 0.5 * z * width == pytest.approx(2.7832)


def test_band_limited_plan_asks_a_fraction_of_the_ankle_torque():
    """A brake-then-accelerate at the envelope's edge: the limited plan's acceleration steps
    from −a to +a within a sample.  Ridden as is, the rider's trim lean steps with it and he
    pushes over 150 N·m; band-limited to z/2, a fraction of that (docs/ride_falls.md)."""
    p = ride_params(RideAssumptions())
    a = rider_acceleration_limit(p)
    t = np.arange(0.0, 20.0, 0.1)
    v = 8.0 + np.interp(t, [0, 5, 5 + 3 / a, 5 + 6 / a, 20], [0, 0, -3, 0, 0])
    raw = simulate_profile(t, v, p, {}, track_iterations=0, band_limit=False)
    band = simulate_profile(t, v, p, {}, track_iterations=0)
    assert raw.falls == () and band.falls == ()
    assert raw.frame["M_h"].abs().max() > 150.0
    assert band.frame["M_h"].abs().max() < 0.5 * raw.frame["M_h"].abs().max()
    assert any(n.startswith("rider's plan band-limited to z/2") for n in band.notes)
    assert not any("band-limited" in n for n in raw.notes)
    as_logged = simulate_profile(t, v, p, {}, track_iterations=0, lean_share=None)
    assert not any("band-limited" in n for n in as_logged.notes)   # the profile as logged
