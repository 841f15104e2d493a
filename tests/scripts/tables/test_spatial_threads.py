"""3-D rides on threads (scripts/tables/spatial_threads.py): the rides ``simulate_3d``
makes alone, bit for bit; a fall returned in its place."""

from __future__ import annotations

import mujoco
import pytest
from spatial_threads import ride_3d_many

from euc_sim.simulation import native_core
from euc_sim.simulation.engine import default_rider
from euc_sim.simulation.errors import FallError, SimulationError
from euc_sim.simulation.spatial import simulate_3d, write_spatial


def _requests():
    rider = default_rider(noise_std=3.0)          # motor noise: each seed its own trajectory
    return [
        {"path": "figure_eight", "duration": 3.0, "seed": 1, "rider": rider},
        {"path": "slalom", "duration": 3.0, "seed": 2, "rider": rider, "lateral_delay": 0.15},
        {"path": "circle", "duration": 8.0, "speed": 2.5, "radius": 2.0},         # falls
        {"path": "u_turn", "duration": 3.0, "seed": 3, "rider": rider, "integrator": "RK4"},
        {"path": "circle", "duration": 3.0, "seed": 4, "rider": rider, "radius": 5.0},
    ]


def test_rides_on_two_threads_are_the_sequential_rides_bit_for_bit():
    assert native_core.available()
    reqs = _requests()
    done = []
    got = ride_3d_many(reqs, nthread=2, progress=done.append)
    assert done == list(range(1, len(reqs) + 1))
    for req, res in zip(reqs, got):
        try:
            ref = simulate_3d(**req)
        except FallError as exc:
            assert isinstance(res, FallError) and str(res) == str(exc) and res.quantity == exc.quantity
            continue
        assert res.equals(ref) and res.attrs == ref.attrs
    assert sum(isinstance(r, FallError) for r in got) == 1      # the tight circle, returned not raised
    assert mujoco.get_mjcb_control() is None


def test_written_recordings_are_the_same_files(tmp_path):
    reqs = [{"path": "slalom", "duration": 2.0, "seed": s, "out": tmp_path / "threads" / f"r{s}.csv"}
            for s in (5, 6, 7)]
    paths = ride_3d_many(reqs, nthread=2, ride=write_spatial)
    for req, p in zip(reqs, paths):
        ref = write_spatial(**{**req, "out": tmp_path / "one" / p.name})
        for suffix in (".csv", ".json", ".truth.json"):
            assert p.with_suffix(suffix).read_bytes() == ref.with_suffix(suffix).read_bytes()


def test_bad_input_is_said():
    with pytest.raises(SimulationError, match="nthread"):
        ride_3d_many([], nthread=0)
    with pytest.raises(SimulationError, match="unknown path 'loop'"):
        ride_3d_many([{"path": "slalom", "duration": 1.0}, {"path": "loop", "duration": 1.0}], nthread=2)


def test_blind_study_makes_its_3d_cases_on_threads_as_one_by_one(tmp_path):
    """The blind study's 3-D cases, made by ``make_recordings`` (one in-process task,
    two threads): the files ``make_recording`` writes case by case; a fall left unwritten."""
    import blind_study

    cases = blind_study.plan_spatial(7, 3, 2.0)
    cases.append({**cases[0], "name": "spatial_falls", "maneuver": "circle", "duration": 8.0,
                  "options": {"speed": 2.5, "radius": 2.0}})
    blind_study.make_recordings(cases, tmp_path / "threads", workers=1)
    (tmp_path / "one").mkdir()
    for c in cases[:-1]:
        p = blind_study.make_recording(c, tmp_path / "one")
        for suffix in (".csv", ".json", ".truth.json"):
            q = tmp_path / "threads" / p.with_suffix(suffix).name
            assert q.read_bytes() == p.with_suffix(suffix).read_bytes()
    with pytest.raises(FallError):
        blind_study.make_recording(cases[-1], tmp_path / "one")
    assert sorted(p.name for p in (tmp_path / "threads").iterdir()) == sorted(
        p.name for p in (tmp_path / "one").iterdir())
