"""The simulation read as a ride log is written (euc_sim.rides.sim.reading)."""

import numpy as np
import pytest
from scipy.signal import lfilter

from euc_sim.rides.grids.rider_features import band_ratio_db
from euc_sim.rides.sim.reading import READING_MEAN, read_as_logged, stamp_readings
from euc_sim.rides.sim.tracking import to_grid

DT = 1e-3


def test_a_reading_is_the_mean_over_the_time_before_its_stamp():
    t = np.arange(0.0, 10.0 + DT / 2, DT)
    r = stamp_readings(t, 3.0 * t, np.array([1.0, 4.37, 9.9]))
    # the mean of 3 t over the 200 samples ending at the stamp: 3 (s − 0.2/2 + dt/2)
    assert r == pytest.approx(3.0 * (np.array([1.0, 4.37, 9.9]) - READING_MEAN / 2 + DT / 2), abs=2e-3)


def test_stamps_outside_the_simulation_read_nothing_and_repeated_stamps_are_read_once():
    t = np.arange(0.0, 5.0 + DT / 2, DT)
    y = np.sin(t)
    assert np.isnan(stamp_readings(t, y, np.array([-1.0, 6.0, 5.0 + 1.5 * READING_MEAN]))).all()
    assert np.isfinite(stamp_readings(t, y, np.array([-0.5 * READING_MEAN, 5.0 + 0.5 * READING_MEAN]))).all()
    stamps = np.array([0.5, 1.0, 1.0, 1.6, 2.2, 2.2, 2.9])
    grid = np.arange(0.0, 4.0, 0.1)
    out = read_as_logged(t, y, stamps, grid)
    assert np.isnan(out[grid < 0.5]).all() and np.isnan(out[grid > 2.9 + 1e-9]).all()
    inside = (grid >= 0.5) & (grid <= 2.9)
    assert np.isfinite(out[inside]).all()
    st = np.unique(stamps)
    assert out[inside] == pytest.approx(np.interp(grid[inside], st, stamp_readings(t, y, st)))


def _noise(seed: int, n: int) -> np.ndarray:
    """A 3 Hz first-order noise (the rider's motor-noise corner) sampled every DT."""
    a = np.exp(-DT * 2 * np.pi * 3.0)
    return lfilter([1 - a], [1, -a], np.random.default_rng(seed).normal(size=n)) * 40.0


def test_read_as_logged_has_the_spectrum_of_a_log_of_the_same_process_where_the_grid_mean_has_more():
    """A log written at ~5 Hz stamps (0.2 s readings) and a simulation of an independent draw of the
    same process: read at the stamps, the simulation's bands match the log's; averaged straight onto
    the 10 Hz grid, its fastest band is several dB hotter (the log's interpolation never passes it)."""
    n = 600_000
    t = np.arange(n) * DT
    rng = np.random.default_rng(7)
    stamps = np.cumsum(rng.uniform(0.15, 0.25, size=3000))
    stamps = stamps[stamps < t[-1] - 1.0] + 0.5
    grid = np.arange(1.0, stamps[-1] - 1.0, 0.1)
    seg = np.zeros(grid.size, int)
    rows = np.ones(grid.size, bool)
    log = np.interp(grid, stamps, stamp_readings(t, _noise(1, n), stamps))
    sim = _noise(2, n)
    read = band_ratio_db(read_as_logged(t, sim, stamps, grid), log, seg, 10.0, rows)
    assert np.max(np.abs(read.ratio_dB)) < 1.5
    binned = band_ratio_db(to_grid(t, sim, grid), log, seg, 10.0, rows)
    assert binned.ratio_dB[0] > 6.0
