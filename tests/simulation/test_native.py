"""The native MuJoCo closed loop (motor PD and the delayed rider as a numba control callback) against the
Python loop."""

from __future__ import annotations

import ctypes
import threading

import mujoco
import numpy as np
import pytest

from euc_sim.controllers.motor import MotorPD
from euc_sim.simulation import native, native_core
from euc_sim.simulation.effects import PeriodicPush
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
    offs = native_core.field_offsets()
    for name in ("qpos", "qvel", "ctrl"):
        assert ctypes.c_int64.from_address(d._address + offs[name]).value == getattr(d, name).ctypes.data


@pytest.mark.parametrize("variant, motor, effects, maneuver", [
    ("ideal", MotorPD(), {}, "stop_and_go"),
    ("contact", MotorPD(), {}, "constant_speed"),
    ("ideal", MotorPD(tiltback_speed=2.0, voltage=60.0, back_emf=3.0, drop=0.1),
     {"road_slope": 0.05, "rider_mass": 80.0, "wheel_bearing_friction": 0.02}, "stop_and_go"),
])
def test_native_loop_matches_the_python_loop(rider, variant, motor, effects, maneuver):
    kw = dict(rider=rider, seed=3, variant=variant, motor=motor, effects=effects)
    native.LAST_RUN.clear()
    a = simulate(maneuver, 8.0, **kw)
    assert native.LAST_RUN["rows"] == 8001              # it ran natively: every row recorded by the callback
    b = simulate(maneuver, 8.0, native=False, **kw)
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    assert _gap(a, b) <= TOL
    assert mujoco.get_mjcb_control() is None            # nothing leaks into other simulations


def test_native_loop_runs_in_c(rider):
    simulate("stop_and_go", 2.0, rider=rider)
    assert native.available()
    assert native.LAST_RUN["rows"] == 2001              # rows recorded by the callback, the last under mj_forward
    assert native.LAST_RUN["per"] == 4                  # RK4: the callback once per stage, the law once per step


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
    monkeypatch.setitem(native_core._STATE, "callback", None)
    monkeypatch.setattr(native_core, "_compile", broken)
    a = simulate("stop_and_go", 2.0, rider=rider, seed=2)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Python loop" in err[0] and "no numba here" in err[0]
    monkeypatch.undo()
    b = simulate("stop_and_go", 2.0, rider=rider, seed=2, native=False)
    assert _gap(a, b) == pytest.approx(0.0, abs=TOL)


DRAG_ROLL = {"aerodynamic_drag": 0.3, "rolling_resistance": 0.015, "road_slope": 0.02}


@pytest.mark.parametrize("variant, effects, push", [
    ("ideal", DRAG_ROLL, None),
    ("contact", DRAG_ROLL, None),                        # the rolling moment on the spinning wheel
    ("ideal", {"aerodynamic_drag": 0.3}, PeriodicPush(40.0, 0.5)),
])
def test_held_forces_run_natively_as_in_the_python_loop(rider, variant, effects, push):
    """Drag, the rolling-resistance moment and an external force, held over each step by
    the callback: the ride as the Python loop's, and they act (the ride differs without them)."""
    kw = dict(rider=rider, seed=3, variant=variant)
    native.LAST_RUN.clear()
    a = simulate("stop_and_go", 8.0, effects=effects, external_force=push, **kw)
    assert native.LAST_RUN["rows"] == 8001              # it ran natively
    b = simulate("stop_and_go", 8.0, effects=effects, external_force=push, native=False, **kw)
    assert _gap(a, b) <= TOL
    bare = simulate("stop_and_go", 8.0, effects={"road_slope": 0.02} if "road_slope" in effects else {}, **kw)
    assert float(np.max(np.abs(a["x"] - bare["x"]))) > 0.05       # m: the forces moved the ride


def test_a_fall_with_drag_and_rolling_is_raised_at_the_same_time(rider):
    kw = dict(rider=rider.replace(delay=0.6), seed=0, effects=DRAG_ROLL)
    with pytest.raises(FallError) as e_native:
        simulate("stop_and_go", 10.0, **kw)
    with pytest.raises(FallError) as e_python:
        simulate("stop_and_go", 10.0, native=False, **kw)
    assert str(e_native.value) == str(e_python.value)
    a, b = e_native.value.trajectory, e_python.value.trajectory
    assert len(a) == len(b) > 0 and _gap(a, b) <= TOL


def test_held_forces_compiled_are_the_python_law():
    from euc_sim.simulation.effects import held_forces
    from euc_sim.simulation.native_kernels import held_forces as compiled

    for v in (-7.0, -0.004, 0.0, 0.003, 2.5, 11.0):
        args = (v, 0.3, 0.015, 1000.0, 0.2, -12.5)
        assert compiled(*args) == pytest.approx(held_forces(*args), rel=1e-15, abs=1e-15)


MOVING = ({"cog_height_drift": 0.05}, {"lateral_dynamics": 0.15},
          {"cog_height_drift": 0.05, "lateral_dynamics": 0.15, **DRAG_ROLL})


@pytest.mark.parametrize("variant", ["ideal", "contact"])
@pytest.mark.parametrize("effects", MOVING)
def test_height_drift_and_lateral_dynamics_run_natively_as_in_the_python_loop(rider, variant, effects):
    """The tilt and yaw's and the moving G's generalised forces, held over each step, and h(t) in
    the model's body_ipos over the whole step (written at the last callback call of the step
    before): the ride as the Python loop's, and the effects act."""
    kw = dict(rider=rider, seed=3, variant=variant)
    native.LAST_RUN.clear()
    a = simulate("stop_and_go", 6.0, effects=effects, **kw)
    assert native.LAST_RUN["rows"] == 6001              # it ran natively
    b = simulate("stop_and_go", 6.0, effects=effects, native=False, **kw)
    assert list(a.columns) == list(b.columns)           # h, psi, theta as well
    assert _gap(a, b) <= TOL
    rest = {k: v for k, v in effects.items() if k not in ("cog_height_drift", "lateral_dynamics")}
    bare = simulate("stop_and_go", 6.0, effects=rest, **kw)
    assert float(np.max(np.abs(a["phi"] - bare["phi"]))) > 1e-3   # rad: they moved the rider


@pytest.mark.parametrize("integrator", ["mjINT_EULER", "mjINT_IMPLICITFAST"])
def test_a_moving_centre_of_gravity_runs_natively_with_a_one_call_integrator(rider, integrator):
    """With one callback call per step the first call is the last: h_{k+1} goes into the model
    after step k's positions, as with RK4's four."""
    from euc_sim.simulation.engine import _closed_loop, _moving, _raise_fall, prepare

    states = []
    for nat in (True, False):
        r = prepare("stop_and_go", 4.0, rider=rider, seed=3, variant="contact",
                    effects={"cog_height_drift": 0.05, "lateral_dynamics": 0.15})
        r.stepper.m.opt.integrator = getattr(mujoco.mjtIntegrator, integrator)
        if nat:
            forces = (r.ext.k_drag, r.ext.C_rr, r.ext.N_load, r.p_true.R, None)
            out = native.native_loop(r.stepper, r.motor, r.run, 1e-3, r.N, r.y0, r.bounds, _raise_fall,
                                     None, forces, _moving(r.ext, r.p_true, 1e-3))
            assert native.LAST_RUN["per"] == 1
        else:
            out = _closed_loop(r.stepper, r.motor, r.run, r.ext, r.p_true, 1e-3, r.N, r.y0, r.bounds)
        states.append(out[0])
    assert float(np.max(np.abs(states[0] - states[1]))) <= TOL


def test_lateral_and_drift_rows_compiled_are_the_python_laws():
    from euc_sim.model.parameters import TABLE3 as p
    from euc_sim.simulation import drift, effects
    from euc_sim.simulation.native_kernels import drift_force_row, lateral_force_row

    rng = np.random.default_rng(5)
    for _ in range(20):
        g, f, xd, gd, fd, th, thd, psd, psdd = rng.normal(size=9)
        state = (np.sin(g), np.cos(g), np.sin(f), np.cos(f), xd, gd, fd, np.sin(th), np.cos(th), thd, psd, psdd)
        table3 = (p.mw, p.m0, p.m, p.h0, p.l0, p.h, p.R, p.g, p.Jw, p.J0, p.J)
        assert lateral_force_row(*table3, *state) == pytest.approx(effects.lateral_force_rows(p, *state),
                                                                   rel=1e-14, abs=1e-12)
        args = (p.m, p.l0, 0.9 + 0.1 * g, 0.1 * xd, 0.5 * th, g, f, fd)
        assert drift_force_row(*args) == pytest.approx(drift.drift_force_row(*args), rel=1e-14, abs=1e-12)


def test_model_offsets_point_at_the_fields():
    m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><body pos="0 0 1"><joint/><geom size=".1"/>'
                                       '<site name="s" pos="0 0 .2"/></body></worldbody></mujoco>')
    offs = native_core.model_offsets()
    for name in ("body_ipos", "site_pos"):
        assert ctypes.c_int64.from_address(m._address + offs[name]).value == getattr(m, name).ctypes.data


def test_threads_share_the_callback_safely(rider):
    """Runs on threads, each natively with its own context at once; all as the Python loop."""
    from concurrent.futures import ThreadPoolExecutor

    seeds = [0, 1, 2, 3]
    with ThreadPoolExecutor(4) as pool:
        runs = list(pool.map(lambda s: simulate("stop_and_go", 3.0, rider=rider, seed=s), seeds))
    for s, a in zip(seeds, runs):
        assert _gap(a, simulate("stop_and_go", 3.0, rider=rider, seed=s, native=False)) <= TOL
    assert mujoco.get_mjcb_control() is None


def test_the_rider_law_matches_the_python_reference_step_by_step(rider):
    """The rider's state after a native run (integrator z, command history du) is the one
    the Python reference leaves: the law and its buffers advance alike."""
    from euc_sim.controllers.rider import RiderRun
    from euc_sim.simulation.engine import _MujocoStepper, FALL_BOUNDS, _raise_fall
    from euc_sim.model.parameters import TABLE3
    from euc_sim.simulation.maneuvers import make_maneuver

    r6 = rider.replace(K=tuple(rider.K[:5]) + (-40.0,)) if len(rider.K) == 5 else rider
    N, dt = 3000, 1e-3
    v_ref, a_ref = make_maneuver("stop_and_go").reference(np.arange(N + 1) * dt)
    runs = [RiderRun(r6, TABLE3, MotorPD(), v_ref, a_ref, dt, seed=5) for _ in range(2)]
    v0, g0, f0, _ = runs[0].initial_state()
    y0 = (0.0, g0, f0, v0, 0.0, 0.0)
    stepper = _MujocoStepper(TABLE3, "ideal", dt, {}, None)
    stepper.reset(y0)
    states, U = native.native_loop(stepper, MotorPD(), runs[0], dt, N, y0, FALL_BOUNDS, _raise_fall)
    n = runs[1].n
    Y = [y0] * n + [tuple(s) for s in states]
    M_h = [runs[1].command(k, Y)[1] for k in range(N + 1)]      # the reference law on the same states
    assert np.max(np.abs(np.array(M_h) - U[:, 1])) <= 1e-9
    assert runs[0].z == pytest.approx(runs[1].z, abs=1e-12) and runs[1].z != 0.0
    assert np.max(np.abs(runs[0].du - runs[1].du)) <= 1e-9


def test_a_foreign_simulation_is_left_alone_while_native_runs_go(rider):
    """The callback is process-wide; an MjData it does not know keeps its own controls.

    A handshake, no clock: the ride's first progress call (inside its native run, the
    callback installed) lets the foreign simulation go and waits until it has stepped."""
    from concurrent.futures import ThreadPoolExecutor

    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><joint name="j"/><geom size=".1" mass="1"/></body></worldbody>'
        '<actuator><motor joint="j"/></actuator></mujoco>')
    d = mujoco.MjData(m)
    installed, stepped = threading.Event(), threading.Event()

    def hold(_t):
        if not installed.is_set():
            installed.set()
            stepped.wait(120)                       # the ride stays native while the foreign one steps

    def foreign():
        try:
            installed.wait(120)
            seen = [mujoco.get_mjcb_control() is not None]
            for _ in range(200):
                d.ctrl[0] = 0.25
                mujoco.mj_step(m, d, nstep=50)
                seen.append(float(d.ctrl[0]))
            return seen
        finally:
            stepped.set()

    with ThreadPoolExecutor(2) as pool:
        ride = pool.submit(simulate, "stop_and_go", 6.0, rider=rider, seed=1, progress=hold)
        seen = pool.submit(foreign).result()
        ride.result()
    assert installed.is_set()
    assert seen == [True] + [0.25] * 200
