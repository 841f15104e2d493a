"""The change test and the wheel identity check of rides/logbook/history.py."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.rides.logbook.history import change_test, series_cells


def test_change_test_calibrated_under_no_change():
    """Under no change, about 5 % of seeded draws are called changed (not 0, not 30 %)."""
    rng = np.random.default_rng(7)
    calls = 0
    n = 400
    for _ in range(n):
        true = 0.15 + rng.normal(0, 0.01, 5)          # ride-to-ride spread 10 mΩ
        se = 0.004
        x = true + rng.normal(0, se, 5)
        calls += change_test(x, [(v - 1.96 * se, v + 1.96 * se) for v in x]).verdict == "changed"
    assert 0.01 < calls / n < 0.12


def test_change_test_sees_a_large_step():
    x = [0.150, 0.155, 0.148, 0.152, 0.230]
    ch = change_test(x, [(v - 0.008, v + 0.008) for v in x])
    assert ch.verdict == "changed" and ch.difference == pytest.approx(0.0787, abs=0.005)
    assert ch.difference_ci95[0] > 0


def test_series_cells():
    assert 20 in series_cells(84.0, 70.0) and 24 not in series_cells(84.0, 70.0)
    assert series_cells(150.0, 130.0) == (36, 40, 42)
