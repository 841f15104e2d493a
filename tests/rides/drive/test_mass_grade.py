"""The mass's climb term (euc_sim.rides.drive.mass, ``grade``) on a twin ride over a known hill.

How the climb is read from noisy GPS altitude (in time or over distance) is measured in
studies/mass_grade.py (docs/real_rides.md, "One road grade"); here the term itself: on an
exact altitude its coefficient is the mass, and a log without altitude has none.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivesynth import DRIVE, drive_log
from euc_sim.rides.drive.mass import fit_mass
from euc_sim.rides.grids.power import MassSettings, power_signals
from euc_sim.rides.source.logs import read_log

FAST = MassSettings(n_boot=20)


def road(s):
    """The road's true grade sin α and altitude (m) at s m along it."""
    w1, w2 = 2 * np.pi / 700.0, 2 * np.pi / 260.0
    grade = 0.05 * np.sin(w1 * s) + 0.02 * np.sin(w2 * s + 1.0)
    alt = 40.0 - 0.05 / w1 * np.cos(w1 * s) - 0.02 / w2 * np.cos(w2 * s + 1.0)
    return grade, alt


def test_on_exact_altitude_the_grade_coefficient_is_the_mass(tmp_path):
    log = read_log(drive_log(tmp_path / "hill.csv", seed=3, road=road, alt_sd=0.0),
                   emit_warnings=False)
    fit = fit_mass(log, FAST)
    assert "grade" in fit.terms
    assert fit.coef["grade"] == pytest.approx(DRIVE["mass"], rel=0.05)
    assert fit.estimate == pytest.approx(DRIVE["mass"], rel=0.05)


def test_the_climb_follows_the_hill(tmp_path):
    log = read_log(drive_log(tmp_path / "hill.csv", seed=3, road=road, alt_sd=0.0),
                   emit_warnings=False)
    sig = power_signals(log, FAST)
    v = sig.raw["v"]
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(sig.t))])
    h = sig.raw["h"]
    ok = np.isfinite(h)
    # the energy windows' altitude is the road's (to the GPS's 0.1 m steps and the filter's ends)
    assert np.max(np.abs(h[ok] - road(s[ok])[1])) < 1.0


def test_a_flat_altitude_reads_no_climb(tmp_path):
    sig = power_signals(read_log(drive_log(tmp_path / "flat.csv", seed=5, duration=200.0), emit_warnings=False), FAST)
    assert sig.climb is not None
    assert np.nanmax(np.abs(sig.climb)) < 1e-9


def test_without_altitude_there_is_no_climb(tmp_path):
    sig = power_signals(read_log(drive_log(tmp_path / "nogps.csv", seed=5, duration=200.0, gps=False), emit_warnings=False), FAST)
    assert sig.climb is None and "h" not in sig.raw
    assert "grade" in fit_mass(read_log(drive_log(tmp_path / "n.csv", seed=5, duration=200.0, gps=False), emit_warnings=False),
                               FAST).unidentified
