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


@pytest.fixture(scope="module")
def hill(tmp_path_factory):
    d = tmp_path_factory.mktemp("hill")
    return read_log(drive_log(d / "hill.csv", seed=3, road=road, alt_sd=1.0), emit_warnings=False)


def test_the_grade_coefficient_is_the_mass(hill):
    fit = fit_mass(hill, FAST)
    assert "grade" in fit.terms
    # β_h = m when the climb is read right: the 1 m altitude errors over 100 m of road
    # leave it within a few per cent (a 10 s time derivative of them does not)
    assert fit.coef["grade"] == pytest.approx(DRIVE["mass"], rel=0.08)
    assert fit.estimate == pytest.approx(DRIVE["mass"], rel=0.05)
    assert fit.ci95[0] <= DRIVE["mass"] <= fit.ci95[1]


def test_the_climb_is_speed_times_the_distance_grade(hill):
    sig = power_signals(hill, FAST)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (sig.raw["v"][1:] + sig.raw["v"][:-1])
                                         * np.diff(sig.t))])
    true_rate = sig.raw["v"] * road(s)[0]
    moving = sig.v > 2.0
    err = sig.climb[moving] / G - true_rate[moving]
    assert np.sqrt(np.mean(err ** 2)) < 0.3 * np.std(true_rate[moving])
    # the energy windows' Δh/T is the window mean of the same climb rate, exactly
    n = window_samples_odd(4.0, FAST.rate)
    _, cols = energy_regressors(sig, 0, n, FAST.rate)
    hdot = climb_rate(sig.t, sig.raw["v"], np.interp(sig.t, hill.data["t"][hill.data["gps_alt"].notna()],
                                                     hill.data["gps_alt"].dropna()))
    want = G * window_mean(hdot, sig.segment, n)
    ok = np.isfinite(cols["grade"]) & np.isfinite(want)
    assert ok.mean() > 0.9
    assert np.max(np.abs(cols["grade"][ok] - want[ok])) < 0.05 * np.std(want[ok])
    # over the ride it climbs what the road climbs
    assert sig.raw["h"][-1] - sig.raw["h"][0] == pytest.approx(road(s[-1])[1] - road(0.0)[1], abs=3.0)


def test_a_flat_altitude_reads_no_climb(tmp_path):
    sig = power_signals(drive_log(tmp_path / "flat.csv", seed=5, duration=200.0), FAST)
    assert sig.climb is not None and np.all(sig.climb == 0.0) and np.all(sig.raw["h"] == 0.0)


def test_without_altitude_there_is_no_climb(tmp_path):
    sig = power_signals(drive_log(tmp_path / "nogps.csv", seed=5, duration=200.0, gps=False), FAST)
    assert sig.climb is None and "h" not in sig.raw
