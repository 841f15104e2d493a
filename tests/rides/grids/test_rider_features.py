"""Bands of a channel (euc_sim.rides.grids.rider_features): the held-out level-and-spectrum score."""

import numpy as np
import pytest
from scipy.signal import lfilter

from euc_sim.rides.grids.rider_features import BAND_WINDOWS, RiderFitError, band_ratio_db


def _ride(seed: int, n: int = 6000) -> np.ndarray:
    """10 Hz battery power: a slow swing and a first-order 1 Hz noise, W."""
    a = np.exp(-0.1 * 2 * np.pi * 1.0)
    e = lfilter([1 - a], [1, -a], np.random.default_rng(seed).normal(size=n)) * 900.0
    return 500.0 + 300.0 * np.sin(2 * np.pi * 0.02 * np.arange(n) / 10.0) + e


def test_twice_the_power_is_six_db_in_every_band():
    y = _ride(0)
    seg = np.zeros(y.size, int)
    out = band_ratio_db(2.0 * y, y, seg, 10.0, np.ones(y.size, bool))
    assert out.windows_s == list(BAND_WINDOWS)
    assert out.ratio_dB == pytest.approx([20 * np.log10(2.0)] * len(BAND_WINDOWS), abs=1e-9)
    assert out.rms_dB == pytest.approx(20 * np.log10(2.0), abs=1e-9)


def test_an_independent_draw_scores_near_zero_db_where_its_rms_error_is_large():
    y, z = _ride(0), _ride(1)
    seg = np.zeros(y.size, int)
    out = band_ratio_db(z, y, seg, 10.0, np.ones(y.size, bool))
    assert out.rms_dB < 1.5
    fast = y - np.convolve(y, np.ones(50) / 50, mode="same")
    assert np.sqrt(np.mean((z - y) ** 2)) > 1.2 * np.sqrt(np.mean(fast ** 2))


def test_rows_where_either_is_nan_are_left_out_on_both_sides():
    y = _ride(2)
    seg = np.zeros(y.size, int)
    z = y.copy()
    z[3000:] = np.nan
    rows = np.ones(y.size, bool)
    whole = band_ratio_db(z, y, seg, 10.0, rows)
    assert whole.rms_dB == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(RiderFitError, match="at least 2 finite rows"):
        band_ratio_db(np.full(y.size, np.nan), y, seg, 10.0, rows)
