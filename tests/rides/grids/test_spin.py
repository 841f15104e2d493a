"""The wheel spinning off the ground (euc_sim.rides.grids.spin.free_spin) against riding that
only looks fast (hard acceleration and braking, a sudden stop, rows stamped 10 ms apart), and
left out of every grid of a ride (grids/signals.resample, grids/law_signals)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from euc_sim.rides.balance.design import balance_design
from euc_sim.rides.balance.fit import fit_balance
from euc_sim.rides.grids.signals import RideAssumptions, resample, ride_signals
from euc_sim.rides.grids.spin import free_spin, spin_rows
from euc_sim.rides.source.logs import Ride


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

M = 100.0


def _log(spin: bool) -> Ride:
    """A 5 Hz ride with a stop at 300-320 s; with ``spin``, the wheel lifted there spins
    0 → 30 m/s in 0.8 s and coasts down over 2 s, drawing no power."""
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 600.0, 0.2)
    v = 6.0 + 2.0 * np.sin(2 * np.pi * t / 80) + np.sin(2 * np.pi * t / 17)
    v = v * np.clip(np.abs(t - 310.0) / 10.0 - 1.0, 0.0, 1.0)     # standing still 300-320 s
    a = np.gradient(v, t)
    P = 20.0 + M * a * v + 0.02 * M * 9.81 * v + 0.3 * v ** 3 + rng.normal(0, 30, t.size)
    if spin:
        up = (t >= 309.0) & (t < 309.8)
        down = (t >= 309.8) & (t < 311.8)
        v = np.where(up, 30.0 * (t - 309.0) / 0.8, v)
        v = np.where(down, 30.0 * (1 - (t - 309.8) / 2.0), v)
    data = pd.DataFrame({"t": t, "v": v, "voltage": np.full_like(t, 84.0), "current": P / 84.0,
                         "tilt": np.zeros_like(t), "torque": np.zeros_like(t)})
    return Ride(path="spin.csv", layout="eucworld", variant="", data=data,
                   start=pd.Timestamp("2026-01-01"), absent=(), warnings=(), n_rows_read=len(t),
                   n_rows_merged=0)


def test_the_spin_is_found_and_riding_is_not():
    log = _log(spin=True)
    rows = spin_rows(log.data)
    t = log.data["t"].to_numpy()
    assert rows.any() and np.all((t[rows] >= 308.9) & (t[rows] <= 311.9))
    assert not spin_rows(_log(spin=False).data).any()
    assert free_spin(np.zeros(0), np.zeros(0)).size == 0


def test_every_grid_leaves_the_spin_out_and_splits_the_ride_there():
    frame, notes = resample(_log(spin=True))
    assert frame["v"].max() < 10.0
    assert frame["segment"].nunique() == 2
    assert any("spins off the ground" in n and "split" in n for n in notes)
    bridged, notes = resample(_log(spin=True), max_gap=np.inf)     # the simulated profile's grid
    assert bridged["segment"].nunique() == 1 and bridged["v"].max() < 10.0
    assert any("bridged linearly" in n for n in notes)


def test_a_spin_does_not_wreck_the_balance_fit():
    A = RideAssumptions(total_mass=M, m_eq=M)
    names = ["rolling_resistance", "aerodynamic_drag", "drivetrain_idle_loss"]
    fits = [fit_balance(balance_design(ride_signals(_log(s), A)), names, n_boot=0) for s in (False, True)]
    assert fits[1].rmse == pytest.approx(fits[0].rmse, rel=0.05)
    assert fits[1].estimate["aerodynamic_drag"] == pytest.approx(0.3, abs=0.05)
