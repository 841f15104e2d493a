"""The road's grade from GPS altitude read over distance (euc_sim/rides/grids/route.gps_grade)
and the balance's climb term built on it (twin rides with a known road)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from euc_sim.rides.balance.crossride import admissible
from euc_sim.rides.balance.design import NOMINAL, PLAUSIBLE, balance_design
from euc_sim.rides.balance.fit import fit_balance
from euc_sim.rides.grids.route import GRADE_LENGTH_M, MAX_GRADE, distance_along, gps_grade
from euc_sim.rides.grids.signals import RideAssumptions, ride_signals
from euc_sim.rides.source.logs import Ride

M, G, C_RR, P0 = 110.0, 9.81, 0.02, 30.0


def road(s):
    """The road's true grade sin α and altitude (m) at s m along it."""
    w1, w2 = 2 * np.pi / 700.0, 2 * np.pi / 260.0
    grade = 0.05 * np.sin(w1 * s) + 0.02 * np.sin(w2 * s + 1.0)
    alt = 40.0 - 0.05 / w1 * np.cos(w1 * s) - 0.02 / w2 * np.cos(w2 * s + 1.0)
    return grade, alt


def _ride(seed: int, duration: float = 1200.0, alt_sd: float = 1.0, settle_m: float = 0.0):
    """A 5 Hz log with battery power from the energy balance on the road, and a GPS
    altitude at 1 Hz with slow (10 s) errors of ``alt_sd`` m, rounded to 0.1 m;
    ``settle_m``: the fix starts 80 m high and settles over that much road."""
    from scipy.signal import lfilter

    rng = np.random.default_rng(seed)
    dt = 0.2
    t = np.arange(0.0, duration, dt)
    ph = rng.uniform(0, 2 * np.pi, 3)
    v = (6.0 + 2.0 * np.sin(2 * np.pi * t / 90 + ph[0]) + 1.0 * np.sin(2 * np.pi * t / 23 + ph[1])
         + 0.5 * np.sin(2 * np.pi * t / 7 + ph[2])) * np.clip(t / 20.0, 0, 1) * np.clip(
        (duration - t) / 20.0, 0, 1)
    s = distance_along(t, v)
    grade, alt = road(s)
    a = np.gradient(v, t)
    P = P0 + M * a * v + C_RR * M * G * v + M * G * v * grade + rng.normal(0.0, 40.0, len(t))
    rho = math.exp(-1.0 / 10.0)
    err = lfilter([1.0], [1.0, -rho], rng.normal(0, alt_sd * math.sqrt(1 - rho ** 2), len(t)))
    fix = np.arange(len(t)) // 5 * 5                    # a new fix each second, held between
    gps_alt = np.round((alt + err)[fix], 1)
    if settle_m > 0:
        gps_alt = gps_alt + 80.0 * np.clip(1.0 - s / settle_m, 0.0, 1.0)
    data = pd.DataFrame({"t": t, "v": v, "voltage": np.full_like(t, 84.0), "current": P / 84.0,
                         "gps_alt": gps_alt})
    log = Ride(path=f"hill{seed}.csv", layout="eucworld", variant="", data=data,
                  start=pd.Timestamp("2026-01-01"), absent=(), warnings=(), n_rows_read=len(t),
                  n_rows_merged=0)
    return ride_signals(log, RideAssumptions(total_mass=M, m_eq=M))


@pytest.fixture(scope="module")
def hill():
    return _ride(3)


def _true_grade(raw):
    return road(distance_along(raw["t"].to_numpy(), raw["v"].to_numpy()))[0]


def test_the_grade_is_read_from_altitude_over_distance(hill):
    raw = hill.raw
    est, true = gps_grade(raw), _true_grade(raw)
    moving = raw["v"].to_numpy() > 1.0
    err = est[moving] - true[moving]
    # 1 m of slow error over 100 m of road: about ±0.014 against a grade of RMS 0.038
    assert np.sqrt(np.mean(err ** 2)) < 0.02
    gain = np.dot(est[moving], true[moving]) / np.dot(est[moving], est[moving])
    assert gain == pytest.approx(1.0, abs=0.15)        # what a regression on it recovers


def test_gps_error_attenuates_what_the_grade_explains():
    """Slower, larger altitude errors lower the gain a regression on the grade finds:
    why road_slope_gps's plausible range reaches down to 0 (errors-in-variables attenuation)."""
    gains = []
    for sd in (0.5, 2.0):
        raw = _ride(5, alt_sd=sd).raw
        est, true = gps_grade(raw), _true_grade(raw)
        gains.append(np.dot(est, true) / np.dot(est, est))
    assert gains[0] > 0.9 and 0.5 < gains[1] < 0.8


def test_the_balance_finds_the_climb_with_a_gain_near_one(hill):
    d = balance_design(hill)
    assert "road_slope_gps" in d.candidates
    names = list(NOMINAL) + ["rolling_resistance", "drivetrain_idle_loss", "road_slope_gps"]
    fit = fit_balance(d, names, n_boot=0)
    lo, hi, _ = PLAUSIBLE["road_slope_gps"]
    assert fit.estimate["road_slope_gps"] == pytest.approx(1.0, abs=0.2)
    assert lo < fit.estimate["road_slope_gps"] < hi
    assert "road_slope_gps" in admissible(fit, ["road_slope_gps"])
    assert fit.estimate["rolling_resistance"] == pytest.approx(C_RR, abs=0.005)


def test_a_settling_fix_is_not_read_as_road():
    sig = _ride(4, duration=600.0, settle_m=150.0)
    raw = sig.raw
    s = distance_along(raw["t"].to_numpy(), raw["v"].to_numpy())
    est = gps_grade(raw)
    assert np.all(np.abs(est) <= MAX_GRADE)
    assert np.all(est[s < 150.0] == 0.0)                        # unknown, not −0.5
    far = s > 150.0 + 2 * GRADE_LENGTH_M
    assert np.sqrt(np.mean((est[far] - _true_grade(raw)[far]) ** 2)) < 0.015


def test_short_rides_and_bad_arguments():
    raw = pd.DataFrame({"t": np.arange(200) * 0.1, "v": np.full(200, 1.0),
                        "gps_alt": 10.0 + 0.02 * np.arange(200) * 0.1})
    assert np.allclose(gps_grade(raw), 0.02, atol=1e-9)         # 20 m of road: one straight line
    assert np.all(gps_grade(raw.iloc[:50]) == 0.0)              # 5 m: too short to read
    with pytest.raises(ValueError, match="gps_alt"):
        gps_grade(raw.drop(columns="gps_alt"))
    with pytest.raises(ValueError, match="two finite altitudes"):
        gps_grade(raw.assign(gps_alt=np.nan))
