"""lateral_dynamics' peak tilt (CONTRACT): the peak over the couplings' bandwidth, one
definition for a simulation's truth and the diagnosis's estimate."""

import numpy as np
import pytest

from euc_sim.simulation.effects import LATERAL_WINDOW, band_peak_tilt


def _turn_with_wobble(dt: float, wobble: float):
    """A 0.1 rad turn lean (8 s period) plus a 6 Hz balance wobble of amplitude ``wobble``."""
    t = np.arange(0.0, 12.0, dt)
    return 0.1 * np.sin(2 * np.pi * t / 8.0) + wobble * np.sin(2 * np.pi * 6.0 * t + 0.3)


def test_the_peak_tilt_is_the_turn_not_the_wobble():
    theta = _turn_with_wobble(1e-3, 0.03)
    peak = band_peak_tilt(theta, 1e-3)
    assert np.max(np.abs(theta)) > 0.125                 # the raw peak carries the wobble
    assert peak == pytest.approx(0.1, rel=0.03)          # the coupling band does not
    assert band_peak_tilt(_turn_with_wobble(1e-3, 0.0), 1e-3) == pytest.approx(0.1, rel=0.01)


def test_the_truth_at_1khz_and_the_recording_at_120hz_read_the_same_quantity():
    fine = band_peak_tilt(_turn_with_wobble(1e-3, 0.03), 1e-3)
    coarse = band_peak_tilt(_turn_with_wobble(1 / 120, 0.03), 1 / 120)
    assert coarse == pytest.approx(fine, rel=0.01)


def test_a_wider_band_lowers_a_sharp_peak():
    t = np.arange(0.0, 10.0, 1e-3)
    theta = 0.1 * np.exp(-((t - 5.0) / 0.3) ** 2)
    assert band_peak_tilt(theta, 1e-3, 2 * LATERAL_WINDOW) < band_peak_tilt(theta, 1e-3) < 0.1


def test_a_record_shorter_than_two_windows_is_refused():
    with pytest.raises(ValueError, match=r"theta: expected a 1-D tilt of at least 122 samples"):
        band_peak_tilt(np.zeros(100), 1 / 120)
