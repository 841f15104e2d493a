"""The simulated rider along real profiles: the acceleration envelope that keeps him up (issue 21).

InMotion V9 ride 0 (``../shared/data/euc_core``, skipped when absent): the rider fell at
t = 842.9 s braking at 3.5 m/s² then speeding up at 2 m/s² within a second.  Only the
30 s window around it is ridden here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from euc_sim.controllers.rider import trim
from euc_sim.controllers.motor import MotorPD
from euc_sim.model.parameters import TABLE3
from euc_sim.rides.grids.profile import speed_profile
from euc_sim.rides.grids.signals import RideAssumptions
from euc_sim.rides.sim.simulate import ride_params
from euc_sim.rides.sim.envelope import LEAN_SHARE, resisting_acceleration, rider_acceleration_limit
from euc_sim.rides.sim.tracking import simulate_profile
from euc_sim.simulation.engine import FALL_BOUNDS
from euc_sim.rides.source.logs import read_log

V9_0 = Path(__file__).resolve().parents[4] / "shared" / "data" / "euc_core" / "trips" / "inmotion" / "v9" / "0" / "0.csv"


def test_acceleration_limit_is_where_the_steady_lean_reaches_its_share():
    a = rider_acceleration_limit(TABLE3)
    phi = [abs(float(trim(TABLE3, MotorPD(), s * a)[1])) for s in (1.0, -1.0)]
    assert max(phi) == pytest.approx(LEAN_SHARE * FALL_BOUNDS["phi"], abs=1e-3)
    worst = 1.0 if phi[0] >= phi[1] else -1.0          # the limiting direction: a bit more leans past the share
    assert abs(float(trim(TABLE3, MotorPD(), worst * 1.05 * a)[1])) > LEAN_SHARE * FALL_BOUNDS["phi"] + 1e-3
    assert rider_acceleration_limit(TABLE3, lean_share=0.5) > a
    with pytest.raises(ValueError, match="lean_share"):
        rider_acceleration_limit(TABLE3, lean_share=1.2)


def test_rolling_resistance_and_slope_narrow_the_envelope():
    p = ride_params(RideAssumptions())
    assert resisting_acceleration(p, {}) == pytest.approx(0.0, abs=1e-12)
    assert resisting_acceleration(p, {"rolling_resistance": 0.02}) == pytest.approx(0.02 * p.g)
    t = np.arange(0.0, 20.0, 0.1)
    v = np.clip(t - 2.0, 0.0, 6.0)                                 # 1 m/s², within the bare envelope
    free = simulate_profile(t, v, p, {}, track_iterations=0)
    assert not any(n.startswith("profile acceleration limited") for n in free.notes)
    rolled = simulate_profile(t, v, p, {"rolling_resistance": 0.1}, track_iterations=0)
    assert rolled.falls == ()
    assert any(f"±{rider_acceleration_limit(p) - 0.1 * p.g:.2f} m/s²" in n for n in rolled.notes)
    stuck = simulate_profile(t, v, p, {"rolling_resistance": 0.2}, track_iterations=0)
    assert stuck.frame is None and "exceeds what the simulated rider" in stuck.falls[0]["cause"]


@pytest.fixture(scope="module")
def v9_window():
    if not V9_0.is_file():
        pytest.skip("../shared/data/euc_core absent")
    prof = speed_profile(read_log(V9_0, emit_warnings=False))
    t, v = prof["t"].to_numpy(), prof["v"].to_numpy()
    keep = (t >= 820.0) & (t <= 850.0)
    return t[keep] - t[keep][0], v[keep]


def test_v9_0_old_fall_window_is_ridden(v9_window):
    t, v = v9_window
    params = ride_params(RideAssumptions())
    as_logged = simulate_profile(t, v, params, {}, track_iterations=0, lean_share=None)
    assert as_logged.falls and as_logged.falls[0]["t"] == pytest.approx(22.9, abs=0.5)   # 842.9 s
    run = simulate_profile(t, v, params, {}, track_iterations=0)
    assert run.falls == ()
    assert run.frame["phi"].abs().max() < FALL_BOUNDS["phi"] - 0.1
    note = next(n for n in run.notes if n.startswith("profile acceleration limited"))
    assert f"±{rider_acceleration_limit(params):.2f} m/s²" in note
    v_sim = np.interp(t, run.frame["t"], run.frame["x_dot"])
    assert np.sqrt(np.mean((v_sim - v) ** 2)) < 1.0       # still rides the logged speeds, m/s
