"""The native MuJoCo closed loop (motor PD as a numba control callback) against the Python loop."""

from __future__ import annotations

import ctypes

import mujoco
import numpy as np
import pytest

from controllers.motor import MotorPD
from euc_sim.simulation import native
from euc_sim.simulation.engine import default_rider, simulate
from euc_sim.simulation.errors import FallError

TOL = 1e-9   # rad, rad/s, m: issue 23's bound between the two loops


@pytest.fixture(scope="module")
def rider():
    return default_rider(noise_std=3.0)


def _gap(a, b) -> float:
    return max(float(np.max(np.abs(a[c].to_numpy() - b[c].to_numpy()))) for c in a.columns)


def test_offsets_point_at_the_fields():
    d = mujoco.MjData(mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><joint name="j"/><geom size=".1"/></body></worldbody>'
        '<actuator><motor joint="j"/></actuator></mujoco>'))
    offs = native.field_offsets()
    for name in ("qpos", "qvel", "ctrl", "qfrc_applied", "xfrc_applied"):
        assert ctypes.c_int64.from_address(d._address + offs[name]).value == getattr(d, name).ctypes.data


@pytest.mark.parametrize("variant, motor, effects, maneuver", [
    ("ideal", MotorPD(), {}, "stop_and_go"),
    ("contact", MotorPD(), {}, "constant_speed"),
    ("ideal", MotorPD(tiltback_speed=2.0, voltage=60.0, back_emf=3.0, drop=0.1),
     {"road_slope": 0.05, "rider_mass": 80.0, "wheel_bearing_friction": 0.02}, "stop_and_go"),
    ("ideal", MotorPD(), {"aerodynamic_drag": 0.4, "rolling_resistance": 0.02}, "stop_and_go"),
    ("contact", MotorPD(), {"aerodynamic_drag": 0.4, "rolling_resistance": 0.02, "road_slope": -0.03},
     "stop_and_go"),
])
def test_native_loop_matches_the_python_loop(rider, variant, motor, effects, maneuver):
    kw = dict(rider=rider, seed=3, variant=variant, motor=motor, effects=effects)
    native._I[native._I_K] = -7                          # marker: the native run overwrites it
    a = simulate(maneuver, 8.0, **kw)
    assert int(native._I[native._I_K]) == 8000         # it ran natively: one row per step (the last read after)
    b = simulate(maneuver, 8.0, native=False, **kw)
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    assert _gap(a, b) <= TOL
    assert mujoco.get_mjcb_control() is None            # nothing leaks into other simulations


def test_native_loop_runs_in_c(rider):
    simulate("stop_and_go", 2.0, rider=rider)
    assert native.available()
    assert int(native._I[native._I_K]) == 2000          # rows recorded by the callback, one per step
    assert int(native._I[native._I_CALLS]) == 2000 * int(native._I[native._I_PER])


def test_a_fall_is_raised_at_the_same_time(rider):
    kw = dict(rider=rider.replace(delay=0.6), seed=0)
    with pytest.raises(FallError) as e_native:
        simulate("stop_and_go", 10.0, **kw)
    with pytest.raises(FallError) as e_python:
        simulate("stop_and_go", 10.0, native=False, **kw)
    assert str(e_native.value) == str(e_python.value)
    a, b = e_native.value.trajectory, e_python.value.trajectory      # the run up to the fall
    assert len(a) == len(b) > 0
    assert _gap(a, b) == pytest.approx(0.0, abs=TOL)


def test_progress_is_the_simulated_time_in_both_loops(rider):
    seen = {True: [], False: []}
    for nat in (True, False):
        simulate("stop_and_go", 2.0, rider=rider, seed=1, native=nat, progress=seen[nat].append)
    assert seen[True] == seen[False] and seen[True][0] == 0.0 and 1.5 < seen[True][-1] <= 2.0


def test_fallback_when_numba_cannot_compile(rider, monkeypatch, capsys):
    def broken():
        raise ImportError("no numba here")
    monkeypatch.setattr(native, "_CALLBACK", None)
    monkeypatch.setattr(native, "_compile", broken)
    a = simulate("stop_and_go", 2.0, rider=rider, seed=2)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Python loop" in err[0] and "no numba here" in err[0]
    monkeypatch.undo()
    b = simulate("stop_and_go", 2.0, rider=rider, seed=2, native=False)
    assert _gap(a, b) == pytest.approx(0.0, abs=TOL)


def test_per_step_effects_keep_the_python_loop(rider):
    native._I[native._I_K] = -7                          # marker: untouched by a Python run
    simulate("stop_and_go", 1.0, rider=rider, effects={"cog_height_drift": 0.05})
    assert int(native._I[native._I_K]) == -7


def test_drag_and_rolling_act_in_the_native_loop(rider):
    """The callback's drag and rolling moment change the ride as the Python loop's do (above)."""
    bare = simulate("stop_and_go", 4.0, rider=rider, seed=3)
    dragged = simulate("stop_and_go", 4.0, rider=rider, seed=3,
                       effects={"aerodynamic_drag": 0.4, "rolling_resistance": 0.02})
    assert int(native._I[native._I_EFF]) == 1
    assert _gap(bare, dragged) > 1e-3


def test_threads_share_the_callback_safely(rider):
    """Runs on threads: one holds the callback, the others take the Python loop; all exact."""
    from concurrent.futures import ThreadPoolExecutor

    seeds = [0, 1, 2, 3]
    with ThreadPoolExecutor(4) as pool:
        runs = list(pool.map(lambda s: simulate("stop_and_go", 3.0, rider=rider, seed=s), seeds))
    for s, a in zip(seeds, runs):
        assert _gap(a, simulate("stop_and_go", 3.0, rider=rider, seed=s, native=False)) <= TOL
    assert mujoco.get_mjcb_control() is None
