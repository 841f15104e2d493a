"""The simulated steps of a ride on threads: the same numbers as one after the other, and an
interruption that ends the running steps instead of waiting for them."""

from __future__ import annotations

import sys
import threading
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from ridesynth import synth_log  # noqa: E402

from euc_sim.controllers.motor import MotorPD  # noqa: E402
from euc_sim.report.ride.contract import simulation_json  # noqa: E402
from euc_sim.rides.source.logs import read_log

NOM = {"copper_loss": 0.004, "drivetrain_idle_loss": 10.0}


@pytest.fixture(scope="module")
def short_ride(tmp_path_factory):
    """A 120 s synthetic WheelLog ride (stops at both ends, a 2 s gap) and its signals."""
    from euc_sim.rides.grids.signals import ride_signals

    path = synth_log(tmp_path_factory.mktemp("threads") / "ride.csv", seed=3, duration=120.0, gap_at=60.0)
    ride = read_log(path, emit_warnings=False)
    return ride, ride_signals(ride)


def _steps():
    """Three steps that ride differently (law, effects, power model): three jobs on two threads."""
    from euc_sim.rides.sim.sim_steps import SimStep

    return [SimStep("nominal", "paper PD", MotorPD(), None, {}, NOM),
            SimStep("stiff", "a stiffer law", MotorPD(Kp=900.0, Kd=60.0), None,
                    {"rolling_resistance": 0.015}, dict(NOM, drivetrain_idle_loss=20.0)),
            SimStep("skipped", "never run", why="for the test"),
            SimStep("dragged", "drag and a slope", MotorPD(), None,
                    {"aerodynamic_drag": 0.3, "road_slope": 0.01}, NOM)]


def test_threads_give_the_serial_numbers_bit_for_bit(short_ride):
    """Each step's draws are its own (seeded by its index), so order and threads do not matter:
    the table, errors, bands, notes and falls are identical, not merely close (the claim is
    identity, so the comparison is exact)."""
    from euc_sim.rides.sim.simulate import simulate_ride

    path, sig = short_ride
    serial = simulate_ride(sig, _steps(), path, seed=5, track_iterations=1, workers=1)
    threaded = simulate_ride(sig, _steps(), path, seed=5, track_iterations=1, workers=2)
    assert serial.ran == ["nominal", "stiff", "dragged"]
    assert {"v_stiff", "P_dragged", "M_nominal"} <= set(serial.table)
    pd.testing.assert_frame_equal(threaded.table, serial.table, check_exact=True)
    assert simulation_json(threaded) == simulation_json(serial)
    assert threaded.errors == serial.errors and threaded.notes == serial.notes
    # the steps did ride differently: identical results are not identical steps
    assert not np.array_equal(serial.table["P_stiff"].to_numpy(), serial.table["P_dragged"].to_numpy())


def test_a_step_is_what_it_is_alone(short_ride):
    """A step's columns do not depend on the steps run beside it (its draws are seeded by its
    index, not taken from a generator the others consume)."""
    from euc_sim.rides.sim.simulate import simulate_ride

    path, sig = short_ride
    steps = _steps()
    both = simulate_ride(sig, steps, path, seed=5, track_iterations=0, workers=2)
    first = simulate_ride(sig, steps[:1], path, seed=5, track_iterations=0, workers=1)
    for col in ("v_nominal", "M_nominal", "P_nominal"):
        np.testing.assert_array_equal(both.table[col].to_numpy(), first.table[col].to_numpy())


def test_an_interruption_cancels_the_running_ride():
    """One job fails (an interruption) while another rides a long profile on the other thread:
    the failure is raised here, and the long ride ends, cancelled, instead of riding its ten
    minutes out."""
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.sim.pool import run_threads
    from euc_sim.rides.sim.tracking import RideCancelled, simulate_profile

    t = np.arange(0.0, 600.0, 0.1)
    v = 4.0 + np.sin(2 * np.pi * t / 60.0)
    riding, seen = threading.Event(), []

    def job(which, cancel):
        if which == "interrupt":
            riding.wait(60.0)                       # the other ride has started
            raise KeyboardInterrupt
        try:
            return simulate_profile(t, v, TABLE3, {}, track_iterations=0, stops=(),
                                    progress=lambda msg: riding.set(), cancel=cancel)
        except BaseException as exc:
            seen.append(exc)
            raise

    with pytest.raises(KeyboardInterrupt):
        run_threads(job, ["ride", "interrupt"], workers=2)
    assert riding.is_set() and len(seen) == 1 and isinstance(seen[0], RideCancelled)


def test_one_worker_runs_in_order_in_this_thread():
    from euc_sim.rides.sim.pool import run_threads

    where, done = [], []
    out = run_threads(lambda job, cancel: where.append(threading.current_thread()) or job * 2,
                      [1, 2, 3], workers=1, on_done=lambda i, k: done.append((i, k)))
    assert out == [2, 4, 6] and set(where) == {threading.current_thread()}
    assert done == [(0, 1), (1, 2), (2, 3)]
    assert run_threads(lambda job, cancel: job + 1, [1, 2, 3], workers=2) == [2, 3, 4]


def _stop_and_go(fall_in_second: bool = False):
    """90 s: three stretches of riding between standing stops (10 s each); with
    ``fall_in_second``, the second stretch asks for 8 m/s within 0.2 s."""
    t = np.arange(0.0, 90.0, 0.1)
    v = np.zeros_like(t)
    for lo, hi in ((2.0, 22.0), (32.0, 52.0), (62.0, 82.0)):
        ride = (t > lo) & (t < hi)
        v[ride] = 3.0 * np.sin(np.pi * (t[ride] - lo) / (hi - lo)) ** 2
    if fall_in_second:
        v[(t > 40.0) & (t < 45.0)] = 8.0
    return t, v


@pytest.mark.parametrize("fall", [False, True])
def test_stretches_on_a_pool_are_the_stretches_one_by_one(fall):
    """The stretches between stops ridden side by side give the frame they give one by one;
    after a fall in the second, the third is not part of the run either way."""
    from concurrent.futures import ThreadPoolExecutor

    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.sim.tracking import simulate_profile

    t, v = _stop_and_go(fall)
    kw = dict(track_iterations=0 if fall else 1, seed=4, lean_share=None if fall else 0.3)
    one = simulate_profile(t, v, TABLE3, {"rolling_resistance": 0.01}, **kw)
    with ThreadPoolExecutor(2) as pool:
        side = simulate_profile(t, v, TABLE3, {"rolling_resistance": 0.01}, pool=pool, **kw)
    assert any("stands still at 4 stops" in n for n in one.notes), one.notes
    assert bool(one.falls) == fall and side.falls == one.falls and side.notes == one.notes
    if fall:
        assert 32.0 < one.falls[0]["t"] < 52.0 and one.frame["t"].iloc[-1] < 52.0    # in the second
    pd.testing.assert_frame_equal(side.frame, one.frame, check_exact=True)
