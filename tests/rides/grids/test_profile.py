"""The simulated ride's speed profile (euc_sim/rides/grids/profile.py): wheel-speed spikes the
battery cannot pay for are bridged, paid accelerations and descents are kept."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from euc_sim.rides.grids.profile import speed_profile, unpaid_spikes
from euc_sim.rides.source.logs import Ride

M = 150.0                       # kg, rider and wheel


def _log(t, v, P) -> Ride:
    data = pd.DataFrame({"t": t, "v": v, "voltage": np.full_like(t, 84.0), "current": P / 84.0})
    return Ride(path="synthetic.csv", layout="eucworld", variant="", data=data,
                   start=pd.Timestamp("2026-01-01"), absent=(), warnings=(), n_rows_read=len(t),
                   n_rows_merged=0)


def _cruise(seed: int):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.18, 0.22, 600))              # 5 Hz with jitter, about 120 s
    t -= t[0]
    v = 6.0 + 0.02 * rng.standard_normal(t.size)
    P = 400.0 + 50.0 * rng.standard_normal(t.size)            # cruising: drag and rolling
    return t, v, P


def test_an_unpaid_spike_is_found_and_bridged():
    t, v, P = _cruise(1)
    k = np.searchsorted(t, 60.0)
    v[k + 1:k + 6] += [1.0, 2.0, 1.5, 0.8, 0.3]                # +2 m/s in 0.4 s, back within 1 s
    P[k + 1:k + 6] = [800.0, -300.0, 0.0, 0.0, 100.0]         # no power behind it
    spikes = unpaid_spikes(_log(t, v, P), M)
    assert len(spikes) == 1
    a, b = spikes[0]
    assert a <= k + 1 and b >= k + 5 and t[b] - t[a] < 3.0
    prof = speed_profile(_log(t, v, P), total_mass=M)
    near = (prof["t"] > 58) & (prof["t"] < 63)
    assert prof.loc[near, "v"].max() < 6.3                    # the rider never sped up
    assert any("1 wheel-speed spike" in n and f"{t[a]:.1f} s" in n for n in prof.attrs["notes"])
    raw = speed_profile(_log(t, v, P))                        # without a mass: as logged
    assert raw.loc[near, "v"].max() > 7.0 and not any("spike" in n for n in raw.attrs["notes"])


def test_a_wheel_spinning_free_on_a_plateau_is_bridged_to_where_it_comes_back():
    t, v, P = _cruise(4)
    k = np.searchsorted(t, 60.0)
    spin = np.interp(t[k + 1:k + 30] - t[k], [0.0, 0.8, 2.2, 4.0], [3.0, 28.0, 28.0, 0.0])
    v[k + 1:k + 30] += spin                                   # up 28 m/s, held 1.4 s, back by 4 s
    P[k + 1:k + 30] = 1000.0
    (a, b), = unpaid_spikes(_log(t, v, P), M)
    assert t[a] <= 60.0 and v[b] <= v[a] + 0.5                # ends back near the rise's start
    prof = speed_profile(_log(t, v, P), total_mass=M)
    assert prof.loc[(prof["t"] > 58) & (prof["t"] < 66), "v"].max() < 6.5


@pytest.mark.parametrize("case", ["paid", "descent"])
def test_a_paid_acceleration_or_a_descent_is_kept(case):
    t, v, P = _cruise(2)
    a_ride = 1.5 if case == "paid" else 1.2                   # m/s²
    ramp = np.clip(t - 60.0, 0.0, 2.0) * a_ride               # 2 s of acceleration, then held
    v = v + ramp
    if case == "paid":                                        # m·a·v, the battery pays (η = 1)
        P = P + np.where((t > 60.0) & (t < 62.0), M * a_ride * v, 0.0)
    else:                                                     # coasting down a 13 % grade
        P = np.where((t > 60.0) & (t < 62.0), 0.0, P)
    assert unpaid_spikes(_log(t, v, P), M) == []


def test_a_bad_mass_is_refused():
    t, v, P = _cruise(3)
    with pytest.raises(ValueError, match="total_mass"):
        unpaid_spikes(_log(t, v, P), 0.0)
