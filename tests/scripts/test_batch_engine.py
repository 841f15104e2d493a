"""The batch engine (scripts/batch_engine.py) against the per-ride engines (1e-9 rad), falls, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from batch_engine import simulate_batch

from euc_sim.simulation.engine import default_rider, simulate
from euc_sim.simulation.errors import FallError, SimulationError
from euc_sim.simulation.maneuvers import make_maneuver

RIDER = default_rider(noise_std=3.0)
MANS = [make_maneuver("deceleration", v0=3.0, v1=1.5, start=0.5, ramp=1.5), make_maneuver("stop_and_go"),
        make_maneuver("deceleration", v0=3.0, v1=1.5, start=0.5, ramp=1.5)]
SEEDS = [11, 12, 13]


T = 2.0


@pytest.fixture(scope="module")
def batch():
    return simulate_batch(MANS, T, seeds=SEEDS, rider=RIDER)


# The per-ride engines themselves differ by ~1e-9 rad over a few seconds (MuJoCo's RK4
# in its joint coordinates vs DOP853 on eq. 5: 1.07e-9 rad at 2.5 s on ride 0); the
# batch engine integrates eq. 5 and follows the analytic engine to ~1e-12 rad.
@pytest.mark.parametrize("engine, rides, tol", [("mujoco", (0, 1, 2), 1e-9), ("analytic", (0, 1), 1e-11)])
def test_batch_matches_the_per_ride_engines(batch, engine, rides, tol):
    for r in rides:
        ref = simulate(MANS[r], T, rider=RIDER, seed=SEEDS[r], engine=engine)
        got = batch.ride(r)
        for col in ("gamma", "phi"):
            assert np.max(np.abs(got[col].to_numpy() - ref[col].to_numpy())) < tol
        assert np.max(np.abs(got["x"].to_numpy() - ref["x"].to_numpy())) < 1e-8
        assert np.array_equal(got["v_ref"].to_numpy(), ref["v_ref"].to_numpy())
        assert np.max(np.abs(got["M_h"].to_numpy() - ref["M_h"].to_numpy())) < 1e-5
    assert not batch.fell.any()
    assert not np.array_equal(batch.y[:, 1, 0], batch.y[:, 1, 2])     # own noise per ride


def test_a_fall_is_flagged_at_the_per_ride_engines_time():
    bounds = {"phi": 0.28}
    run = simulate_batch(MANS, 2.5, seeds=SEEDS, rider=RIDER, fall_bounds=bounds, stride=10)
    assert run.y.shape == (251, 6, 3)
    for r in range(3):
        try:
            simulate(MANS[r], 2.5, rider=RIDER, seed=SEEDS[r], fall_bounds=bounds)
            assert not run.fell[r]
        except FallError as exc:
            assert run.fell[r] and run.t_fall[r] == pytest.approx(exc.t, abs=1e-12)
    assert run.fell.any() and not run.fell.all()
    r = int(np.argmax(run.fell))
    frozen = run.t > run.t_fall[r] + 0.01
    assert np.all(run.y[frozen, :, r] == run.y[frozen][-1, :, r])


def test_bad_batch_requests_name_the_argument():
    with pytest.raises(SimulationError, match="one seed per maneuver"):
        simulate_batch(MANS, 1.0, seeds=[1])
    with pytest.raises(SimulationError, match="stride must be a positive integer, got 0"):
        simulate_batch(MANS, 1.0, seeds=SEEDS, stride=0)
