"""The wheel spinning off the ground (euc_sim.rides.report.spin.free_spin) against riding that
only looks fast: hard acceleration and braking, a sudden stop, rows stamped 10 ms apart."""

from __future__ import annotations

import numpy as np

from euc_sim.rides.report.spin import free_spin


def test_hard_riding_and_timestamp_jitter_are_no_spin():
    """0.8 g of acceleration and braking, a sudden stop from 30 km/h and near-repeated
    rows 10 ms apart are the ride, not a spin."""
    t = np.arange(0.0, 60.0, 0.2)
    v = np.clip(np.minimum(0.8 * 9.81 * (t - 5.0), 0.8 * 9.81 * (40.0 - t)), 0, 15.0)
    assert not free_spin(t, v).any()
    stop = np.where(t < 30.0, 30 / 3.6, 0.0)
    assert not free_spin(t, stop).any()
    tj = np.sort(np.r_[t, t[::7] + 0.01])
    vj = np.interp(tj, t, v) + np.where(np.isin(tj, t[::7] + 0.01), 0.5, 0.0)
    assert not free_spin(tj, vj).any()
    spike = v.copy()
    spike[150] += 15.0                                      # one row 54 km/h off: not the ride
    assert np.flatnonzero(free_spin(t, spike)).tolist() == [150]
