"""The mass's climb from the road's grade read over distance (euc_sim.rides.grids.power.climb_rate):
a twin ride over a known hill, its GPS altitude off by metres."""

from __future__ import annotations

import numpy as np
import pytest

from drivesynth import DRIVE, drive_log
from euc_sim.rides.drive.energy import window_mean, window_samples_odd
from euc_sim.rides.drive.mass import energy_regressors, fit_mass
from euc_sim.rides.grids.power import G, MassSettings, climb_rate, power_signals
from euc_sim.rides.source.logs import read_log

FAST = MassSettings(n_boot=20)


def road(s):
    """The road's true grade sin α and altitude (m) at s m along it."""
    w1, w2 = 2 * np.pi / 700.0, 2 * np.pi / 260.0
    grade = 0.05 * np.sin(w1 * s) + 0.02 * np.sin(w2 * s + 1.0)
    alt = 40.0 - 0.05 / w1 * np.cos(w1 * s) - 0.02 / w2 * np.cos(w2 * s + 1.0)
    return grade, alt


def _hill(tmp_path, alt_sd):
    return read_log(drive_log(tmp_path / f"hill{alt_sd}.csv", seed=3, road=road, alt_sd=alt_sd),
                    emit_warnings=False)


@pytest.fixture(scope="module")
def hill(tmp_path_factory):
    return _hill(tmp_path_factory.mktemp("hill"), 1.0)


def _true_climb(sig):
    """The road's climb rate v·sin α at each grid row, m/s (distance at the corrected speed)."""
    v = sig.raw["v"]
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(sig.t))])
    return v * road(s)[0]


def test_on_exact_altitude_the_grade_coefficient_is_the_mass(tmp_path):
    fit = fit_mass(_hill(tmp_path, 0.0), FAST)
    assert "grade" in fit.terms
    assert fit.coef["grade"] == pytest.approx(DRIVE["mass"], rel=0.03)
    assert fit.estimate == pytest.approx(DRIVE["mass"], rel=0.05)


def test_metre_noisy_altitude_attenuates_it_only_by_the_grades_own_error(hill):
    """1 m of slow altitude error over 100 m of road leaves the grade ±0.013 against a road of
    RMS 0.038: a regression on it recovers about 0.9 of the climb (errors in variables), and
    β_h/m is that gain, not the 0.2-0.3 of a time derivative."""
    sig = power_signals(hill, FAST)
    fit = fit_mass(hill, FAST, sig=sig)
    est, true = sig.climb / G, _true_climb(sig)
    moving = (sig.v > 2.0) & np.isfinite(est)
    gain = np.dot(est[moving], true[moving]) / np.dot(est[moving], est[moving])
    assert 0.8 < gain < 1.0
    assert "grade" in fit.terms
    assert fit.coef["grade"] / fit.coef["inertia"] == pytest.approx(gain, abs=0.1)
    assert fit.estimate == pytest.approx(DRIVE["mass"], rel=0.05)
    assert fit.ci95[0] <= DRIVE["mass"] <= fit.ci95[1]


def test_the_climb_is_speed_times_the_distance_grade(hill):
    sig = power_signals(hill, FAST)
    true_rate = _true_climb(sig)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (sig.raw["v"][1:] + sig.raw["v"][:-1])
                                         * np.diff(sig.t))])
    moving = sig.v > 2.0
    err = sig.climb[moving] / G - true_rate[moving]
    # ±0.013 of grade (1 m over 100 m) against a road of RMS 0.038: about a third of the climb
    assert np.sqrt(np.mean(err ** 2)) < 0.45 * np.std(true_rate[moving])
    # the energy windows' Δh/T is the window mean of the same climb rate, exactly
    n = window_samples_odd(4.0, FAST.rate)
    _, cols = energy_regressors(sig, 0, n, FAST.rate)
    hdot = climb_rate(sig.t, sig.raw["v"], np.interp(sig.t, hill.data["t"][hill.data["gps_alt"].notna()],
                                                     hill.data["gps_alt"].dropna()))
    want = G * window_mean(hdot, sig.segment, n)
    ok = np.isfinite(cols["grade"]) & np.isfinite(want)
    assert ok.mean() > 0.9
    assert np.max(np.abs(cols["grade"][ok] - want[ok])) < 0.05 * np.std(want[ok])
    # over the ride it climbs what the road climbs (1 m of altitude error at either end)
    assert sig.raw["h"][-1] - sig.raw["h"][0] == pytest.approx(road(s[-1])[1] - road(0.0)[1], abs=3.0)


def test_a_flat_altitude_reads_no_climb(tmp_path):
    sig = power_signals(drive_log(tmp_path / "flat.csv", seed=5, duration=200.0), FAST)
    assert sig.climb is not None
    assert np.nanmax(np.abs(sig.climb)) < 1e-9 and np.max(np.abs(sig.raw["h"])) < 1e-9


def test_without_altitude_there_is_no_climb(tmp_path):
    sig = power_signals(drive_log(tmp_path / "nogps.csv", seed=5, duration=200.0, gps=False), FAST)
    assert sig.climb is None and "h" not in sig.raw
