"""MuJoCo rides in one mujoco.batch.Batch on threads against simulate(), ride by ride."""

from __future__ import annotations

import ctypes

import mujoco
import numpy as np
import pytest

from euc_sim.controllers.motor import MotorPD
from euc_sim.simulation import mujoco_batch as mb
from euc_sim.simulation import native_core
from euc_sim.simulation.effects import PeriodicPush
from euc_sim.simulation.engine import default_rider, simulate
from euc_sim.simulation.errors import FallError, SimulationError
from euc_sim.simulation.maneuvers import make_maneuver

TOL = 1e-9   # rad, rad/s, m, N·m: issue 23's bound between a batch ride and simulate()


@pytest.fixture(scope="module")
def rider():
    return default_rider(noise_std=3.0)


def _gap(a, b) -> float:
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    return max(float(np.max(np.abs(a[c].to_numpy() - b[c].to_numpy()))) for c in a.columns)


def _requests(rider) -> list[dict]:
    """Rides that differ in maneuver, seed, motor, parameters and every effect the batch applies."""
    push = PeriodicPush(amplitude=15.0, frequency=0.7)
    return [
        dict(maneuver="stop_and_go", duration=4.0, seed=1, rider=rider),
        dict(maneuver=make_maneuver("acceleration", v0=1.0, v1=3.5, start=0.5, ramp=2.0), duration=4.0,
             seed=2, rider=rider, effects={"aerodynamic_drag": 0.4, "rolling_resistance": 0.02}),
        dict(maneuver="constant_speed", duration=4.0, seed=3, rider=rider,
             effects={"road_slope": 0.05, "rider_mass": 82.0, "wheel_bearing_friction": 0.03,
                      "aerodynamic_drag": 0.3}),
        dict(maneuver="stop_and_go", duration=4.0, seed=4, rider=rider, external_force=push,
             motor=MotorPD(tiltback_speed=2.0, voltage=60.0, back_emf=3.0, drop=0.1),
             effects={"rolling_resistance": 0.03, "sensor_time_offset": 0.01}),
        dict(maneuver="constant_speed", duration=4.0, seed=5),          # the rider designed on its params
    ]


def test_batch_rides_match_simulate(rider):
    reqs = _requests(rider)
    out = mb.simulate_rides(reqs, nthread=2)
    assert mb.available()
    for r, got in zip(reqs, out):
        want = simulate(**r)
        assert _gap(got, want) <= TOL, r
        assert got.attrs == want.attrs
    assert mujoco.get_mjcb_control() is None            # nothing leaks into other simulations


def test_threads_and_batch_sizes_give_the_same_rides(rider):
    """Threads do not change a ride: one thread or two on one batch, and one thread or two on
    batches of one (the pipeline: each thread its own Batch, the calling thread preparing the
    next) are bit-identical; batch sizes change the batched sums' rounding only."""
    reqs = _requests(rider)[:3]
    one, two = mb.simulate_rides(reqs, nthread=1, batch=2), mb.simulate_rides(reqs, nthread=2)
    for a, b in zip(one, two):
        assert _gap(a, b) == pytest.approx(0.0, abs=1e-15)
    reqs = [dict(r, duration=d) for d in (1.0, 0.8) for r in reqs] + [dict(reqs[0], effects={"cog_height_drift": 0.01})]
    assert sum(map(mb.batchable, reqs)) == 6 >= mb.PIPELINE_BATCHES * 2   # 6 batches of one, 2 groups: the pipeline
    counts = []
    single = mb.simulate_rides(reqs, nthread=1, batch=1)
    piped = mb.simulate_rides(reqs, nthread=2, batch=1, progress=counts.append)
    for r, c, d in zip(reqs, single, piped):
        assert _gap(c, d) == pytest.approx(0.0, abs=1e-15)
        assert _gap(d, simulate(**r)) <= TOL
    assert counts == [1, 2, 3, 4, 5, 6, 7]                    # the unbatched ride last


def test_a_failure_in_the_pipeline_is_raised_and_the_threads_stop(rider, monkeypatch):
    """A batch that fails on a thread, and a request refused only as its batch is prepared,
    are raised in the caller; no thread and no callback stay behind."""
    import threading

    reqs = [dict(maneuver="constant_speed", duration=0.5, seed=s, rider=rider) for s in range(6)]
    run_batch = mb._run_batch
    calls = []

    def fail_second(rides, forces, nthread):
        calls.append(threading.current_thread().name)
        if len(calls) == 2:
            raise ValueError("batch two fails")
        return run_batch(rides, forces, nthread)

    monkeypatch.setattr(mb, "_run_batch", fail_second)
    with pytest.raises(ValueError, match="batch two fails"):
        mb.simulate_rides(reqs, nthread=2, batch=1)
    monkeypatch.setattr(mb, "_run_batch", run_batch)
    assert all(name.startswith("mujoco_batch") for name in calls)      # on the pipeline's threads
    bad = reqs[:5] + [dict(reqs[5], external_force=3.0)]
    monkeypatch.setattr(mb, "_check", lambda r: None)              # as if only set-up found it
    with pytest.raises(SimulationError, match="external_force must be a callable"):
        mb.simulate_rides(bad, nthread=2, batch=1)
    assert not [t for t in threading.enumerate() if t.name.startswith("mujoco_batch")]
    assert mujoco.get_mjcb_control() is None


def test_a_batch_and_native_rides_on_threads_at_once(rider):
    """MuJoCo's control callback is one per process: a batch waits for the native rides in
    flight and holds new ones back (native_core.exclusive), so every ride is as alone."""
    from concurrent.futures import ThreadPoolExecutor

    reqs = _requests(rider)[:2]
    alone = [simulate(**r) for r in reqs]
    with ThreadPoolExecutor(4) as pool:
        singles = [pool.submit(simulate, **r) for r in reqs]
        batches = [pool.submit(mb.simulate_rides, reqs, nthread=1) for _ in range(2)]
        got = [f.result() for f in singles] + [d for f in batches for d in f.result()]
    for a, b in zip(got, alone + alone + alone):
        assert _gap(a, b) <= TOL
    assert mujoco.get_mjcb_control() is None


def test_contact_variant_and_the_torque_limit(rider):
    """The contact ground (its own batch: another layout), and a rider whose ankle limit binds
    (his blocks done step by step by his own RiderRun) until he falls."""
    reqs = [dict(maneuver="constant_speed", duration=2.0, seed=6, rider=rider, variant="contact",
                 effects={"rolling_resistance": 0.02, "aerodynamic_drag": 0.3}),
            dict(maneuver=make_maneuver("acceleration", v0=0.5, v1=4.0, start=0.3, ramp=1.0), duration=3.0,
                 seed=7, rider=rider.replace(torque_limit=100.0))]
    contact, limited = mb.simulate_rides(reqs)
    assert _gap(contact, simulate(**reqs[0])) <= TOL
    with pytest.raises(FallError) as want:
        simulate(**reqs[1])
    assert isinstance(limited, FallError) and str(limited) == str(want.value)
    assert _gap(limited.trajectory, want.value.trajectory) <= TOL
    assert np.max(np.abs(limited.trajectory["M_h"])) > 100.0 - 4 * 3.0     # the limit did bind


def test_a_fall_is_returned_as_simulate_raises_it(rider):
    """A rider that cannot hold the slope: the same FallError (time, trajectory) as simulate()."""
    fall = dict(maneuver="constant_speed", duration=3.0, seed=8, rider=rider.replace(torque_limit=5.0),
                effects={"road_slope": 0.2})
    ok = dict(maneuver="constant_speed", duration=3.0, seed=9, rider=rider)
    got_fall, got_ok = mb.simulate_rides([fall, ok])
    with pytest.raises(FallError) as want:
        simulate(**fall)
    assert isinstance(got_fall, FallError)
    assert str(got_fall) == str(want.value)
    assert _gap(got_fall.trajectory, want.value.trajectory) <= TOL
    assert _gap(got_ok, simulate(**ok)) <= TOL


def test_effects_outside_the_batch_run_through_simulate(rider):
    reqs = [dict(maneuver="constant_speed", duration=2.0, seed=1, rider=rider, effects={"cog_height_drift": 0.03}),
            dict(maneuver="constant_speed", duration=2.0, seed=1, rider=rider, engine="analytic")]
    assert not any(mb.batchable(r) for r in reqs)
    for r, got in zip(reqs, mb.simulate_rides(reqs)):
        assert _gap(got, simulate(**r)) == pytest.approx(0.0, abs=1e-15)


def test_bad_requests_are_refused_before_any_ride(rider):
    with pytest.raises(SimulationError, match="unknown argument 'speed'"):
        mb.simulate_rides([dict(maneuver="constant_speed", speed=2.0)])
    with pytest.raises(SimulationError, match="duration"):
        mb.simulate_rides([dict(maneuver="constant_speed", duration=2.0), dict(duration=-1.0)])
    with pytest.raises(SimulationError, match="rolling_model"):     # a request the batch would not take
        mb.simulate_rides([dict(duration=2.0), dict(duration=1.0, engine="analytic", rolling_model="contact")])
    with pytest.raises(SimulationError, match="batch must be a positive"):
        mb.simulate_rides([dict(duration=2.0)], batch=0)


def test_offsets_point_at_the_fields():
    m = mujoco.MjModel.from_xml_string('<mujoco><size nuserdata="2"/><worldbody><body><joint name="j"/>'
                                       '<geom size=".1"/></body></worldbody><actuator><motor joint="j"/>'
                                       '</actuator></mujoco>')
    d = mujoco.MjData(m)
    names = ("userdata", "qpos", "qvel", "ctrl", "qfrc_applied", "xfrc_applied")
    offs = native_core.field_offsets(names)
    for name in names:
        assert ctypes.c_int64.from_address(d._address + offs[name]).value == getattr(d, name).ctypes.data


def test_dataset_batches_write_what_one_by_one_writes(tmp_path, rider):
    """run_dataset's tasks are batches; each recording is simulated_recording's, and a fall is
    named by recording in the report and the manifest."""
    import json

    import pandas as pd

    from euc_sim.simulation.dataset import RecordingSpec, run_dataset, simulated_recording

    specs = [RecordingSpec(f"r{i}", make_maneuver("stop_and_go", v=2.0 + 0.3 * i), 2.0, 10 + i, rider=rider,
                           effects=(("aerodynamic_drag", 0.3), ("road_slope", 0.01 * i)))
             for i in range(3)]
    specs.append(RecordingSpec("falls", make_maneuver("constant_speed"), 2.0, 1,
                               rider=rider.replace(torque_limit=5.0), effects=(("road_slope", 0.2),)))
    rep = run_dataset(tmp_path, specs, workers=1, progress=False, batch=2, threads=2)
    assert list(rep.results) == ["r0", "r1", "r2"] and list(rep.failed) == ["falls"]
    assert rep.failed["falls"].startswith("FallError: fall at t = ")
    assert json.loads((tmp_path / "dataset.json").read_text())["failed"] == rep.failed
    for spec in specs[:3]:
        want, meta, truth = simulated_recording(spec)
        got = pd.read_csv(rep.results[spec.name])
        assert list(got.columns) == list(want.columns)
        assert np.max(np.abs(got.to_numpy() - want.to_numpy())) <= 1e-6     # CSV text keeps ~1e-12 relative
        assert json.loads(rep.results[spec.name].with_suffix(".truth.json").read_text())["seed"] == spec.seed
