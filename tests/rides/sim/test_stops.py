"""The stop model: the rider stands, foot down, where the log stands still (issue 21)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from euc_sim.controllers.motor import MotorPD
from euc_sim.rides.grids.signals import RideAssumptions
from euc_sim.rides.grids.stops import T_STOP, find_stops, moving_segments, rest_rows
from euc_sim.rides.rider.rider_params import rider_from
from euc_sim.rides.sim import tracking
from euc_sim.rides.sim.simulate import ride_params
from euc_sim.simulation.errors import FallError


def test_find_stops_keeps_stands_of_T_STOP_or_more():
    t = np.arange(0.0, 40.0, 0.1)
    v = np.full(t.size, 5.0)
    v[(t >= 10.0) & (t < 12.0)] = 0.02                 # 1.9 s: a pause, not a stop
    v[(t >= 20.0) & (t < 20.0 + T_STOP + 0.05)] = 0.0  # just over T_STOP
    v[t < 4.0] = -0.05                                  # the ride starts standing
    stops = find_stops(t, v)
    assert stops == [(0, 39), (200, 230)]
    assert t[230] - t[200] >= T_STOP
    assert find_stops(t, np.full(t.size, 3.0)) == []
    for bad in ({"v_max": 0.0}, {"min_duration": -1.0}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            find_stops(t, v, **bad)


def test_moving_segments_run_from_stop_to_stop():
    assert moving_segments(100, []) == [(0, 99)]
    assert moving_segments(100, [(0, 20), (50, 70)]) == [(20, 50), (70, 99)]
    assert moving_segments(100, [(10, 20), (50, 99)]) == [(0, 10), (20, 50)]
    assert moving_segments(100, [(0, 99)]) == []


def test_rest_rows_have_the_simulators_columns():
    from euc_sim.simulation.engine import simulate

    cols = list(simulate("constant_speed", 0.05).columns)
    rest = rest_rows(np.arange(3) * 1e-3, 2.5, 0.01, 0.02, np.zeros(3))
    assert list(rest.columns) == cols
    assert (rest[["x_dot", "gamma_dot", "phi_dot", "M_d", "M_h"]].to_numpy() == 0).all()
    assert (rest["x"] == 2.5).all()


def _stop_profile():
    t = np.arange(0.0, 60.0, 0.1)
    return t, np.interp(t, [0, 5, 15, 18, 38, 41, 60], [0, 4, 4, 0, 0, 4, 4])


def test_a_slow_rider_stands_through_a_stop_instead_of_riding_his_windup_back():
    """The calibrated Lynx rider's mechanism on a synthetic stop (docs/ride_simulation.md):
    0.28 s delay, bandwidth 0.1, rolling resistance 0.025.  Balancing through the 20 s stop he
    rolls back over 1 m/s; with the stop model the wheel stands still and he sets off again."""
    p = ride_params(RideAssumptions())
    t, v = _stop_profile()
    rider = rider_from({"delay": 0.28, "bandwidth": 0.1, "noise_std": 0.0}, p, MotorPD())
    eff = {"rolling_resistance": 0.025}
    through = tracking.simulate_profile(t, v, p, eff, track_iterations=0, rider=rider, stops=())
    stood = tracking.simulate_profile(t, v, p, eff, track_iterations=0, rider=rider)
    assert through.falls == () and stood.falls == ()
    during = lambda f: f[(f["t"] > 19.0) & (f["t"] < 37.0)]          # noqa: E731
    assert during(through.frame)["x_dot"].min() < -1.0
    assert (during(stood.frame)[["x_dot", "M_d", "M_h"]].to_numpy() == 0.0).all()
    f = stood.frame
    assert np.diff(f["t"]).min() == pytest.approx(1e-3) and np.diff(f["t"]).max() == pytest.approx(1e-3)
    assert np.abs(np.diff(f["x"])).max() <= f["x_dot"].abs().max() * 1e-3 + 1e-6   # no jump in position
    assert f["t"].iloc[-1] == pytest.approx(t[-1], abs=1e-6)
    assert f.loc[f["t"] > 50.0, "x_dot"].mean() == pytest.approx(4.0, abs=0.3)   # set off again
    assert any(n.startswith("the log stands still at 1 stop, 20 s") for n in stood.notes)
    assert not any("foot down" in n for n in through.notes)


def test_a_fall_in_a_later_stretch_is_reported_at_the_rides_time(monkeypatch):
    t, v = _stop_profile()
    calls = []

    def fake_ride(t_seg, v_plan, *args):
        calls.append(float(t_seg[-1]))
        ts = np.arange(0.0, float(t_seg[-1]) + 5e-4, 1e-3)
        frame = rest_rows(ts, 0.0, 0.0, 0.0, np.interp(ts, t_seg, v_plan)).assign(
            x=lambda d: d["t"] * 2.0, x_dot=2.0)
        if len(calls) == 2:
            exc = FallError(1.5, "phi", 0.71, 0.7)
            exc.trajectory = frame[frame["t"] <= 1.5]
            raise exc
        return frame

    monkeypatch.setattr(tracking, "_ride", fake_ride)
    run = tracking.simulate_profile(t, v, ride_params(RideAssumptions()), {}, track_iterations=0,
                                    lean_share=None)
    stops = find_stops(t, v)
    assert len(calls) == 2
    assert run.falls[0]["t"] == pytest.approx(t[stops[0][1]] + 1.5)
    f = run.frame
    assert isinstance(f, pd.DataFrame) and f["t"].is_monotonic_increasing
    assert f["t"].iloc[-1] == pytest.approx(run.falls[0]["t"], abs=1e-9)
    assert f["x"].iloc[-1] == pytest.approx(2.0 * (calls[0] + 1.5), abs=1e-6)   # the road goes on


def test_a_profile_that_only_stands_is_stood_through():
    t = np.arange(0.0, 10.0, 0.1)
    run = tracking.simulate_profile(t, np.zeros(t.size), ride_params(RideAssumptions()), {}, track_iterations=0)
    assert run.falls == ()
    assert run.frame["t"].iloc[0] == pytest.approx(0.0) and run.frame["t"].iloc[-1] == pytest.approx(t[-1])
    assert (run.frame[["x", "x_dot", "M_d", "M_h"]].to_numpy() == 0.0).all()
