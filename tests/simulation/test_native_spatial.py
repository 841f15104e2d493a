"""The native 3-D closed loop (motor, riders and path tracking as a numba control callback)
against the Python loop of ``spatial._ride``, the reference."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from euc_sim.controllers.motor import MotorPD
from euc_sim.simulation import native_core, native_spatial
from euc_sim.simulation.engine import default_rider
from euc_sim.simulation.errors import FallError
from euc_sim.simulation.spatial import simulate_3d

TOL = 1e-9   # rad, rad/s, m, N·m: issue 23's bound between the two loops


def _gap(a, b) -> float:
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    return max(float(np.max(np.abs(a[c].to_numpy() - b[c].to_numpy()))) for c in a.columns)


def _both(*args, **kw):
    native_spatial.LAST_RUN.clear()
    a = simulate_3d(*args, **kw)
    assert native_spatial.LAST_RUN["rows"] == len(a)     # every row recorded by the callback
    return a, simulate_3d(*args, native=False, **kw)


@pytest.mark.parametrize("path, kw", [
    ("figure_eight", {}),
    ("slalom", {"lateral_delay": 0.15}),                   # the lateral predictor and turn effort
    ("circle", {"integrator": "RK4", "radius": 5.0,        # four callback calls per step; limits, noise
                "motor": MotorPD(tiltback_speed=1.8, voltage=60.0, back_emf=3.0, drop=0.1)}),
])
def test_native_3d_ride_matches_the_python_loop(path, kw):
    rider = default_rider(noise_std=3.0)
    a, b = _both(path, 6.0, rider=rider, seed=4, **kw)
    assert _gap(a, b) <= TOL
    assert a.attrs == b.attrs
    assert mujoco.get_mjcb_control() is None                # nothing leaks into other simulations


def test_without_delays_the_two_loops_agree_bit_for_bit():
    """Every sum in the same order: the recordings are identical."""
    rider = default_rider(delay=0.0)
    a, b = _both("u_turn", 4.0, rider=rider, seed=0)
    assert a.equals(b)


def test_a_3d_fall_is_raised_at_the_same_step_with_the_same_message():
    for kw in ({"path": "circle", "speed": 2.5, "radius": 3.0}, {"path": "circle", "speed": 2.5, "radius": 2.0}):
        with pytest.raises(FallError) as e_native:
            simulate_3d(duration=8.0, **kw)
        with pytest.raises(FallError) as e_python:
            simulate_3d(duration=8.0, native=False, **kw)
        assert str(e_native.value) == str(e_python.value)
        assert e_native.value.quantity == e_python.value.quantity


def test_3d_fallback_when_numba_cannot_compile(monkeypatch, capsys):
    def broken():
        raise ImportError("no numba here")
    monkeypatch.setitem(native_core._STATE, "callback", None)
    monkeypatch.setattr(native_core, "_compile", broken)
    native_spatial.LAST_RUN.clear()
    a = simulate_3d("slalom", 2.0, seed=2)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Python loop" in err[0] and "no numba here" in err[0]
    assert native_spatial.LAST_RUN == {}
    monkeypatch.undo()
    assert _gap(a, simulate_3d("slalom", 2.0, seed=2)) <= TOL


def test_planar_and_3d_rides_run_natively_together_on_threads():
    """Each simulation has its own context in the registry: rides on threads at once."""
    from concurrent.futures import ThreadPoolExecutor

    from euc_sim.simulation.engine import simulate

    rider = default_rider(noise_std=3.0)
    jobs = [lambda: simulate_3d("slalom", 3.0, seed=1), lambda: simulate_3d("circle", 3.0, seed=2),
            lambda: simulate("stop_and_go", 3.0, rider=rider, seed=3)]
    with ThreadPoolExecutor(3) as pool:
        runs = list(pool.map(lambda job: job(), jobs))
    assert _gap(runs[0], simulate_3d("slalom", 3.0, seed=1, native=False)) <= TOL
    assert _gap(runs[1], simulate_3d("circle", 3.0, seed=2, native=False)) <= TOL
    assert _gap(runs[2], simulate("stop_and_go", 3.0, rider=rider, seed=3, native=False)) <= TOL
    assert mujoco.get_mjcb_control() is None
