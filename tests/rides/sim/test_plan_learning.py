"""The simulated rider's plan learned through his inverted closed loop (euc_sim/rides/sim/plan_learning.py)."""

import numpy as np
import pytest
from scipy.signal import lfilter

from euc_sim.rides.grids.signals import sg
from euc_sim.rides.sim.plan_learning import closed_loop_response, filter_band, inverse_correction

RATE = 10.0


def _resonant(x: np.ndarray) -> np.ndarray:
    """A known stand-in for the rider's loop: unit gain at DC, a resonance near 0.5 Hz (10 Hz grid)."""
    wn, zeta, T = 2 * np.pi * 0.5, 0.15, 1 / RATE
    # bilinear transform of wn²/(s² + 2ζwn s + wn²)
    k = 2 / T
    a0, a1, a2 = k * k + 2 * zeta * wn * k + wn * wn, 2 * wn * wn - 2 * k * k, k * k - 2 * zeta * wn * k + wn * wn
    b = np.array([wn * wn, 2 * wn * wn, wn * wn]) / a0
    return lfilter(b, [1.0, a1 / a0, a2 / a0], x - x[0]) + x[0]


def _wiggly_plan(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return 10.0 + sg(np.cumsum(rng.standard_normal(n)) * 0.05, np.zeros(n, int), RATE, 1.5, 2)


def test_filter_band_is_where_the_log_smoothing_passes_half_the_power():
    band = filter_band(RATE, 1.5, 2)
    assert band == pytest.approx(0.72, abs=0.01)
    t = np.arange(0, 200, 1 / RATE)
    def gain(f):
        x = np.sin(2 * np.pi * f * t)
        return np.std(sg(x, np.zeros(t.size, int), RATE, 1.5, 2)[50:-50]) / np.std(x[50:-50])

    assert gain(band) == pytest.approx(2 ** -0.5, abs=0.02)
    assert gain(0.5 * band) > 0.9
    assert filter_band(RATE, 3.0, 2) < band                  # a longer window passes less


def test_closed_loop_response_recovers_a_known_loop():
    t = np.arange(0, 1200, 1 / RATE)
    plan = _wiggly_plan(t.size, 1)
    f, H, coh = closed_loop_response(t, plan, _resonant(plan))
    w = 2 * np.pi * f
    wn, zeta = 2 * np.pi * 0.5, 0.15
    true = wn * wn / (wn * wn - w * w + 2j * zeta * wn * w)
    sel = (f > 0.1) & (f < 0.7)
    # the bilinear transform warps frequencies slightly: within 10 % in gain up to 0.7 Hz
    assert np.max(np.abs(np.abs(H[sel]) / np.abs(true[sel]) - 1)) < 0.1
    assert np.abs(H[np.argmin(np.abs(f - 0.5))]) > 2.5          # the resonance is seen
    assert coh[sel].min() > 0.95


def test_one_inverse_correction_rides_the_target_within_the_band():
    t = np.arange(0, 1200, 1 / RATE)
    target = _wiggly_plan(t.size, 2)
    v0 = _resonant(target)
    plan1 = target + inverse_correction(t, target, v0, target - v0, filter_band())
    v1 = _resonant(plan1)
    rms = lambda x: float(np.sqrt(np.mean(x[200:-200] ** 2)))  # noqa: E731
    before, after = rms(target - v0), rms(target - v1)
    assert after < 0.15 * before, (before, after)
    # the old correction (the slow error added as it is) leaves the resonance's error
    v_old = _resonant(target + sg(target - v0, np.zeros(t.size, int), RATE, 10.0, 2))
    assert rms(target - v_old) > 0.5 * before


def test_inverse_correction_refuses_a_band_that_is_not_positive():
    t = np.arange(0, 100, 0.1)
    with pytest.raises(ValueError, match="band"):
        inverse_correction(t, t, t, t, 0.0)


def test_the_simulated_rider_learns_a_wiggly_profile():
    """The closed loop (MuJoCo, default rider) amplifies a 0.3 Hz wiggle; one learned plan rides it."""
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.sim.tracking import simulate_profile

    t = np.arange(0, 60, 0.1)
    v = 8.0 + 0.3 * np.sin(2 * np.pi * 0.3 * t) * np.clip(t / 5, 0, 1)
    run = simulate_profile(t, v, TABLE3, {}, track_iterations=1, lean_share=None)
    (note,) = [n for n in run.notes if n.startswith("tracking correction 1")]
    first, learned = (float(x) for x in note.split("riding ")[1].split(" m/s")[0].split(" -> "))
    assert first > 0.2 and learned < 0.1 * first, note
