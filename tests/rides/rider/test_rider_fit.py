"""The rider calibrated on a log (euc_sim.rides.rider.rider_fit): pieces, and a concealed rider recovered."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from euc_sim.report.ride.contract import rider_fit_json
from euc_sim.rides.rider import rider_fit as rf
from euc_sim.rides.source.logs import read_log


def test_band_features_put_a_fast_sway_in_the_fast_band_and_a_slow_one_in_the_slow():
    rate = 10.0
    t = np.arange(0, 120, 1 / rate)
    seg = np.zeros(t.size, int)
    rows = np.ones(t.size, bool)
    fast = rf.band_features(np.sin(2 * np.pi * 2.0 * t), seg, rate, rows)
    slow = rf.band_features(np.sin(2 * np.pi * 0.12 * t), seg, rate, rows)
    assert fast.shape == (len(rf.BAND_WINDOWS),)
    # smoother differences are leaky bands: the 5-sample (0.5 s) smoother passes most of a
    # 2 Hz sway, which peaks in band 2 (S_0.7 - S_1.0); a 0.12 Hz one in the last (S_4.2 - S_6)
    assert np.argmax(fast) == 2 and np.argmax(slow) == len(rf.BAND_WINDOWS) - 1
    doubled = rf.band_features(2 * np.sin(2 * np.pi * 2.0 * t), seg, rate, rows)
    np.testing.assert_allclose(doubled - fast, math.log(2.0), atol=1e-9)   # log RMS: a scale shifts all


def _same(windows, expected):
    assert len(windows) == len(expected), windows
    np.testing.assert_allclose(np.asarray(windows), np.asarray(expected), atol=1e-9)


def test_windows_tile_the_ride_above_walking_speed_after_the_run_in():
    t = np.round(np.arange(0, 100, 0.1), 1)
    ch = pd.DataFrame({"t": t, "segment": np.zeros(t.size, int), "v": np.full(t.size, 5.0)})
    # from the 8 s run-in, 30 s windows 1.5 s apart: two fit in 100 s
    _same(rf.fit_windows(ch, n=2, length=30.0), [(8.0, 38.0), (39.5, 69.5)])
    _same(rf.fit_windows(ch, n=5, length=30.0), [(8.0, 38.0), (39.5, 69.5)])
    _same(rf.fit_windows(ch, n=1, length=20.0), [(8.0, 28.0)])
    # four 20 s tiles (at 8, 29.5, 51, 72.5 s), three kept: tiles 0, 2 (1.5 rounds to 2) and 3
    _same(rf.fit_windows(ch, n=3, length=20.0), [(8.0, 28.0), (51.0, 71.0), (72.5, 92.5)])
    dip = ch.assign(v=np.where((t >= 45.0) & (t < 50.0), 1.0, 5.0))     # a stop: the next window waits
    _same(rf.fit_windows(dip, n=3, length=30.0), [(8.0, 38.0), (50.0, 80.0)])
    slow = ch.assign(v=1.0)
    with pytest.raises(rf.RiderFitError, match="above 2 m/s"):
        rf.fit_windows(slow, n=2, length=30.0)
    # a log whose readings stop every 20 s (V9 0: 409 stops of 1.2-1.8 s): the message says so
    cut = ch.assign(segment=(t // 20).astype(int))
    cut.attrs["gaps"] = {"max_gap": 1.0, "count": 4, "median": 1.4}
    with pytest.raises(rf.RiderFitError, match=r"the longest is 19\.9 s; the log's readings stop for more "
                                               r"than 1 s 4 times \(median 1\.4 s\), which splits the ride into 5"):
        rf.fit_windows(cut, n=2, length=30.0)


def test_a_log_without_battery_power_is_refused(tmp_path):
    p = tmp_path / "ew.csv"
    p.write_text("datetime,speed,tilt\n" + "\n".join(
        f"2025-07-01T10:00:{i // 5:02d}.{(i % 5) * 200:03d}+0200,20.0,1.0" for i in range(100)) + "\n")
    with pytest.raises(rf.RiderFitError, match="battery power"):
        rf.log_channels(read_log(p, emit_warnings=False))


@pytest.mark.parametrize("kw, word", [({"n_boot": 0}, "n_boot"), ({"windows": 0}, "windows"),
                                      ({"window_length": -1.0}, "window_length"),
                                      ({"rounds": (5, 10)}, "rounds"), ({"rounds": ()}, "rounds")])
def test_bad_settings_named_before_any_simulation(kw, word):
    from euc_sim.model.parameters import TABLE3

    with pytest.raises(rf.RiderFitError, match=word):
        rf.fit_rider("no-such-log.csv", params=TABLE3, **kw)


def test_concealed_rider_delay_recovered(tmp_path):
    """A 0.2 s rider (bandwidth 0.4, 5 N·m noise) written as an EUC World log: the fit,
    told only the log, the wheel's law, road and drivetrain, finds the delay within
    ±0.05 s (issue 21) and the noise within a factor 1.5.  A cheap setting (one 80 s
    window, one noise draw, 34 simulations) with the study's 10 s plan; seed 5 has been run
    while the fit was changed (with common draws and the 6 s plan it ended at 0.282 s), so
    this is a regression check, not a score: the study's setting (six 35 s windows, two
    draws) is scored on fresh seeds by studies/rider_calibration.py (docs/rider_calibration.md)."""
    from ridersynth import RIDER, concealed_fit_inputs, eucworld_power_log, rider_ride

    log = eucworld_power_log(rider_ride(5, 110.0, dt=2e-3), tmp_path / "ew.csv", 5)
    fit = rf.fit_rider(read_log(log, emit_warnings=False), windows=1, window_length=80.0, rounds=(12, 10), n_boot=40, seed=5,
                       plan_window=10.0, **concealed_fit_inputs())
    d = fit.params["delay"]
    assert abs(d["value"] - RIDER["delay"]) <= 0.05, fit.params
    # the interval says the log fixes the delay to the issue's ±0.05 s and reaches the band
    # around the truth; with this cheap setting it does not cover the truth itself on this
    # seed (0.218 [0.211, 0.235] s measured; the study's setting: docs/rider_calibration.md)
    assert d["hi"] - d["lo"] <= 0.1 and d["lo"] <= RIDER["delay"] + 0.05, fit.params
    noise_ratio = fit.params["noise_std"]["value"] / RIDER["noise_std"]
    assert abs(np.log(noise_ratio)) <= np.log(1.5), fit.params          # within a factor 1.5
    assert fit.objective < fit.objective_nominal
    js = rider_fit_json(fit)
    assert set(js["params"]) == {"delay", "bandwidth", "noise_std"}
    assert js["rider"]["delay"] == pytest.approx(d["value"])


def test_a_parameter_ending_on_its_bound_is_flagged_and_warned_about():
    center = np.array([0.0, 0.5, 0.5])                 # delay on its lower bound
    boot = np.array([[0.0, 0.4, 0.45], [0.02, 0.6, 0.55], [0.01, 0.5, 0.5]])
    params, notes = rf._param_table(center, boot)
    assert params["delay"]["at_bound"] and not params["bandwidth"]["at_bound"]
    assert params["delay"]["value"] == pytest.approx(rf.RIDER_PARAMS[0].lo)
    assert params["delay"]["bound"] == [rf.RIDER_PARAMS[0].lo, rf.RIDER_PARAMS[0].hi]
    assert len(notes) == 1 and notes[0].startswith("WARNING") and "'delay'" in notes[0]
    b = params["bandwidth"]
    assert b["lo"] <= b["value"] <= b["hi"]


def test_design_points_that_fall_bound_the_region_and_are_replaced(monkeypatch):
    """A plant that cannot be ridden with a delay over 0.2 s: the first round's design (seed 0)
    has 6 of its 14 points there, which left 8 riding points, fewer than a quadratic's 10
    coefficients (the table's Lynx 2, Master Pro 3 and 6 failed so).  Each fallen point now
    moves halfway back to the round's center: the search has its points, ends at the concealed
    optimum (features a known smooth function of the settings), and every fall is recorded
    where the plant cannot be ridden."""
    truth = {"delay": 0.15, "bandwidth": 0.4, "noise_std": 5.0}
    u_true = np.array([p.to_unit(truth[p.name]) for p in rf.RIDER_PARAMS])
    A = np.random.default_rng(1).normal(size=(6, 3))

    def features(x):                                   # smooth, one minimum at the truth
        d = x - u_true
        return A @ d + 0.5 * (A ** 2) @ (d * d)

    calls = []

    def fake(setup, values, rows, block):
        x = np.array([p.to_unit(values[p.name]) for p in rf.RIDER_PARAMS])
        calls.append(values)
        return None if values["delay"] > 0.2 else features(x)

    monkeypatch.setattr(rf, "_simulated_features", fake)
    setup = rf._Setup(None, (), (), None, None, None, {}, {}, 0, 2e-3, 8.0)
    w = np.ones(6)
    center, coef, hull, n_sims, fell = rf._search(setup, None, None, features(u_true), w, (14, 12, 10),
                                                  np.random.default_rng(0), lambda s: None)
    got = rf._values_of(center)
    assert abs(got["delay"] - truth["delay"]) < 0.005, got
    assert abs(math.log(got["bandwidth"] / truth["bandwidth"])) < 0.05, got
    assert len(fell) >= 6 and all(rf._values_of(x)["delay"] > 0.2 for x in fell)
    assert n_sims >= len(calls) - 2 and len(calls) > 14 + 2 * 12 + 2 * 10   # the replacements were simulated
    assert "fell" in rf._fall_note(fell, n_sims)
    # a round whose center lies where the rider falls (a surface's optimum beyond the points that
    # rode: Master Pro 6's second round, 0.285 s) is put back where he rides, not left empty
    pool = ([], [], [], [])
    rf._round(setup, None, None, features(u_true), w, 14, u_true, 0, pool, np.random.default_rng(0))
    beyond = u_true.copy()
    beyond[0] = rf.RIDER_PARAMS[0].to_unit(0.30)
    n0 = len(pool[0])
    new, *_ = rf._round(setup, None, None, features(u_true), w, 12, beyond, 1, pool, np.random.default_rng(1))
    assert rf._values_of(new)["delay"] <= 0.2 + 1e-9 and all(rf._values_of(x)["delay"] <= 0.2 for x in pool[0])
    # its box straddles the edge of the region: fresh points top it up to the 11 that rode it asked
    # for besides its center (the point it moved onto, already in the pool); 9 without them
    assert len(pool[0]) - n0 >= 11
    # without the replacement (the former design) the first round stops
    monkeypatch.setattr(rf, "HALVINGS", 0)
    monkeypatch.setattr(rf, "ROUND_BUDGET", 0)
    with pytest.raises(rf.RiderFitError, match="only 8 of the design points.*10 coefficients"):
        rf._search(setup, None, None, features(u_true), w, (14, 12, 10), np.random.default_rng(0), lambda s: None)


def test_a_path_whose_end_falls_on_the_fits_own_draws_is_not_kept(monkeypatch):
    """A rider near the edge of what the plant carries rides some noise draws and falls on
    others (Blitz 1: 0.310 s rode the check's draws, fell on the fit's own).  A path's end is
    kept only if it rides both: here every rider slower than 0.18 s falls on the fit's own
    draws (seed 0) and the log's features point at 0.19 s, so no path's end is kept."""
    truth = {"delay": 0.19, "bandwidth": 0.4, "noise_std": 5.0}
    u_true = np.array([p.to_unit(truth[p.name]) for p in rf.RIDER_PARAMS])
    A = np.random.default_rng(1).normal(size=(6, 3))
    features = lambda x: A @ (x - u_true) + 0.5 * (A ** 2) @ ((x - u_true) ** 2)   # noqa: E731

    def fake(setup, values, rows, block):
        x = np.array([p.to_unit(values[p.name]) for p in rf.RIDER_PARAMS])
        falls = values["delay"] > 0.25 or (values["delay"] > 0.18 and setup.seed == 0)
        return None if falls else features(x)

    monkeypatch.setattr(rf, "_simulated_features", fake)
    said = []
    setup = rf._Setup(None, (), (), None, None, None, {}, {}, 0, 2e-3, 8.0)
    rf._search(setup, None, None, features(u_true), np.ones(6), (14, 12, 10), np.random.default_rng(0), said.append)
    ends = [s for s in said if s.startswith("rider fit: the paths end at")]
    assert len(ends) == 1 and ends[0].count("(distance inf)") == 2, said[-1]
