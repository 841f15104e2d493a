"""The energy-balance window: one linear filter on both sides of the mass regression."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.rides.drive.energy import window_difference, window_mean, window_samples_odd

RATE = 10.0


def test_window_mean_of_a_derivative_is_the_window_difference():
    """Exact on the grid's piecewise-linear signals: what makes the regression consistent."""
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.normal(size=400))            # a rough, piecewise-linear signal
    seg = np.zeros(400, int)
    seg[250:] = 1
    n = window_samples_odd(2.0, RATE)
    # mean of the slopes over the window's n - 1 intervals
    slopes = np.diff(x) * RATE
    want = np.full(400, np.nan)
    h = n // 2
    for i in range(400):
        lo, hi = i - h, i + h
        if lo >= 0 and hi < 400 and seg[lo] == seg[hi]:
            want[i] = slopes[lo:hi].mean()
    got = window_difference(x, seg, n, RATE)
    assert np.array_equal(np.isnan(got), np.isnan(want))
    assert np.nanmax(np.abs(got - want)) < 1e-9
    # the trapezoidal mean of a linear ramp is its centre value
    ramp = np.arange(400.0)
    assert np.nanmax(np.abs(window_mean(ramp, seg, n) - ramp)) < 1e-9


def test_window_never_crosses_a_segment_or_a_gap():
    x = np.ones(100)
    seg = np.repeat([0, 1], 50)
    x[70] = np.nan
    n = window_samples_odd(1.0, RATE)              # 11 samples
    m = window_mean(x, seg, n)
    assert np.isnan(m[:5]).all() and np.isnan(m[45:55]).all()
    assert np.isnan(m[65:76]).all() and m[20] == 1.0 and m[80] == 1.0


def test_window_samples_odd_rejects_a_bad_window():
    assert window_samples_odd(2.0, RATE) == 21 and window_samples_odd(0.05, RATE) == 3
    with pytest.raises(ValueError, match="window and rate must be positive, got window=-1"):
        window_samples_odd(-1.0, RATE)


def test_blocked_heldout_error_from_grams_is_the_refit_on_each_fold():
    """The mass fit's blocked held-out RMS (signed log: from the blocks' Gram matrices) equals
    refitting by least squares on the rows of every other block and predicting the block."""
    from euc_sim.rides.drive.mass import heldout_rmse
    from euc_sim.stats import time_blocks

    rng = np.random.default_rng(0)
    n = 3000
    t = np.arange(n) * 0.5
    X = np.column_stack([rng.normal(size=n) * 1e4, np.abs(rng.normal(size=n)) * 300,
                         rng.normal(size=n) ** 2 * 50, np.ones(n)])
    y = X @ np.array([100.0, 0.02, 0.3, 20.0]) + rng.normal(size=n) * 500
    label, err = time_blocks(t, 10), np.empty(n)
    for b in range(10):
        test = label == b
        beta = np.linalg.lstsq(X[~test], y[~test], rcond=None)[0]
        err[test] = y[test] - X[test] @ beta
    assert heldout_rmse(X, y, label, True) == pytest.approx(float(np.sqrt(np.mean(err ** 2))), rel=1e-9)
