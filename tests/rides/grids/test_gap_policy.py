"""The one gap policy of a ride's grids (euc_sim/rides/source/gaps.py: GapPolicy): short intervals
bridged by interpolation, long ones splitting every grid and the law's rows alike, and the
grid kept on the Ride."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import euc_sim.rides.grids.power as power
import euc_sim.rides.grids.signals as signals
from euc_sim.rides.grids.law_signals import _rate
from euc_sim.rides.grids.power import MassSettings, power_signals
from euc_sim.rides.source.gaps import GAP_POLICY, GapPolicy
from euc_sim.rides.grids.signals import RideAssumptions, ride_grid, ride_signals
from euc_sim.rides.source.logs import Ride

#: Rows every 0.25 s (exact in binary), with a gap after t = 20 s and another after t = 60 s.
STEP = 0.25


def _stamps(gaps: dict[float, float], end: float = 100.0) -> np.ndarray:
    """Rows every STEP s from 0 to ``end``, none inside ``(start, start + length)`` of each gap."""
    t = np.arange(0.0, end + STEP / 2, STEP)
    for start, length in gaps.items():
        t = t[(t <= start) | (t >= start + length)]
    return t


def _log(t: np.ndarray) -> Ride:
    v = 5.0 + np.sin(0.3 * t)
    data = pd.DataFrame({"t": t, "v": v, "voltage": np.full_like(t, 80.0),
                         "current": 5.0 + 3.0 * np.sin(0.2 * t) - 0.2 * (t % 7 < 1)})
    return Ride(path="gaps.csv", layout="wheellog", variant="old", data=data,
                   start=pd.Timestamp("2026-01-01"), absent=(), warnings=(), n_rows_read=t.size,
                   n_rows_merged=0)


def test_the_policy_bridges_up_to_its_threshold_and_splits_beyond():
    p = GapPolicy(bridge=1.0, rate=10.0)
    assert p.splits(np.array([0.2, 1.0, 1.01, 2.0])).tolist() == [False, False, True, True]
    assert p.pieces(np.array([0.0, 0.2, 1.2, 2.5, 2.7, 5.0])).tolist() == [0, 0, 0, 1, 1, 2]
    assert MassSettings().max_gap == GAP_POLICY.bridge
    assert MassSettings().rate == GAP_POLICY.rate


def test_a_short_gap_is_bridged_and_a_long_one_splits_every_grid():
    # 0.75 s without rows after 20 s (bridged), 3.0 s after 60 s (split)
    ride = _log(_stamps({20.0: 0.75, 60.0: 3.0}))
    frame, notes = ride_grid(ride)
    assert frame["segment"].nunique() == 2 and len(notes) == 1 and "60.00" in notes[0]
    inside = frame[(frame["t"] > 20.0) & (frame["t"] < 20.75)]
    assert len(inside) == 7                                 # 20.1 ... 20.7, interpolated
    assert np.allclose(inside["v"], np.interp(inside["t"], [20.0, 20.75],
                                              5.0 + np.sin(0.3 * np.array([20.0, 20.75]))))
    assert not ((frame["t"] > 60.0) & (frame["t"] < 63.0)).any()
    # the balance grid and the mass grid are this grid, cut at the same place
    sig, psig = ride_signals(ride), power_signals(ride)
    assert np.array_equal(sig.frame["segment"], frame["segment"])
    assert np.array_equal(psig.segment, frame["segment"]) and np.array_equal(psig.t, frame["t"])


def test_the_law_rows_break_their_derivatives_at_the_same_threshold():
    t = _stamps({20.0: 0.75, 60.0: 3.0})
    d = _rate(0.5 * t ** 2, t)
    after = lambda s: int(np.searchsorted(t, s, side="right")) - 1   # noqa: E731
    bridged, split = after(20.0), after(60.0)
    assert np.isfinite(d[[bridged, bridged + 1]]).all()    # the 0.75 s interval: an exact mean rate
    assert np.allclose(d[bridged], 0.5 * (t[bridged + 1] + t[bridged - 1]))
    assert np.isnan(d[[split, split + 1]]).all()           # the 3 s interval: no rate across it


def test_a_piece_shorter_than_the_filter_window_is_left_out():
    # 0.5 s of rows (3 rows) between two 3 s gaps: shorter than the 1.5 s balance window
    t = _stamps({40.0: 3.0, 43.5: 3.0})
    sig = ride_signals(_log(t))
    assert sig.frame["segment"].nunique() == 3
    short = sig.frame[(sig.frame["t"] >= 43.0) & (sig.frame["t"] <= 43.5)]
    assert len(short) == 6 and not short["interior"].any() and short["v"].isna().all()
    assert any("fewer than the 15-sample filter window: left out" in n for n in sig.notes)


def test_the_grid_and_its_filtered_signals_are_kept_on_the_ride(monkeypatch):
    built = []
    for mod, name in ((signals, "resample"), (signals, "_balance_grid"), (power, "_filtered")):
        real = getattr(mod, name)
        monkeypatch.setattr(mod, name, lambda *a, _r=real, _n=name, **k: built.append(_n) or _r(*a, **k))
    ride = _log(_stamps({60.0: 3.0}))
    a = ride_signals(ride)
    b = ride_signals(ride, RideAssumptions(R=0.25))        # another radius: another torque only
    assert power_signals(ride) is power_signals(ride)
    assert sorted(built) == ["_balance_grid", "_filtered", "resample"]
    assert a.raw is b.raw and np.array_equal(a.frame["v"], b.frame["v"], equal_nan=True)
    moving = np.isfinite(a.frame["M"])
    assert moving.any() and np.allclose(b.frame["M"][moving], 1.25 * a.frame["M"][moving])
    ride_signals(ride)
    assert built.count("resample") == 1


@pytest.mark.parametrize("bridge, pieces", [(0.5, 3), (1.0, 2), (4.0, 1)])
def test_a_grid_under_another_policy_is_another_grid(bridge, pieces):
    ride = _log(_stamps({20.0: 0.75, 60.0: 3.0}))
    frame, _ = ride_grid(ride, GapPolicy(bridge=bridge))
    assert frame["segment"].nunique() == pieces
    assert ride_grid(ride)[0]["segment"].nunique() == 2


def test_every_gap_number_of_the_ride_side_is_the_policys():
    """The summary, the charge integral, the plots and the simulation read the one policy."""
    import euc_sim.rides.drive.drivetrain as drivetrain
    from euc_sim.rides.sim.simulate import simulation_obstacle

    assert GAP_POLICY.gap_of("eucworld") == 2.0 and GAP_POLICY.gap_of("wheellog") == GAP_POLICY.gap
    t = np.array([0.0, 0.5, 1.0, 1.6, 2.1, 5.0])
    assert GAP_POLICY.plot_breaks(t).tolist() == [4]                        # 2.9 s > 1.5 × 0.5 s
    assert signals.break_at_gaps(t, t)[0].size == t.size + 1
    # an interval over the policy's 1 s adds no charge, one under it does (3600 A for 0.8 s: 0.8 Ah)
    q = drivetrain.charge_drawn(np.array([0.0, 1.2, 2.0]), np.full(3, 3600.0))
    assert q.tolist() == pytest.approx([0.0, 0.0, 0.8])
    sig = ride_signals(_log(_stamps({60.0: 3.0})))
    assert simulation_obstacle(sig) is None and "longer than 2 s" in simulation_obstacle(sig, 2.0)
