"""cog_height_drift of any smooth shape: named, sized, placed in time."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from euc_sim.diagnosis import drift_term
from euc_sim.diagnosis import pipeline as diagnosis
from euc_sim.simulation.drift import DriftShape


@pytest.fixture(scope="module")
def crouch():
    """A rider crouching by 0.2 m over 6-10 s of a stop-and-go, then staying down."""
    from euc_sim.simulation import dataset
    from euc_sim.simulation.maneuvers import make_maneuver
    shape = DriftShape("ramp", 6.0, 4.0, -1.0)
    spec = dataset.RecordingSpec("crouch", make_maneuver("stop_and_go"), 18.0, 9,
                                 effects=(("cog_height_drift", 0.2),), hide_torques=True,
                                 drift_shape=shape)
    rec, meta, truth = dataset.simulated_recording(spec)
    assert truth["drift_shape"]["kind"] == "ramp"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return diagnosis.diagnose(rec, meta=meta, resimulate=False)


def test_a_crouch_is_named_sized_and_placed(crouch):
    res = crouch
    first = res["effects"][0]
    assert first["name"] == "cog_height_drift"
    assert first["estimate"] == pytest.approx(0.2, rel=0.25)
    assert first["ci95"][0] < first["estimate"] < first["ci95"][1]
    assert res["augmented_rmse"] <= 0.5 * res["nominal_rmse"]
    assert res["windows"] and all(a < 10.5 and b > 5.5 for a, b in res["windows"])   # where h changes
    ht = first["h_of_t"]
    h = np.asarray(ht["h"])
    assert h[0] - h[-1] == pytest.approx(0.2, rel=0.3)       # h went down and stayed down
    assert len(ht["t"]) == len(ht["ci95_halfwidth"]) == h.size
    assert first["shape"]["kind"] in ("ramp", "smooth")


def test_the_scan_picks_the_shape_of_a_clean_ramp():
    t = np.linspace(0.0, 20.0, 601)
    drdh = 5.0 + 3.0 * np.sin(1.3 * t)
    true = {"kind": "ramp", "start": 7.0, "length": 3.0}
    y = -drdh * 0.15 * drift_term.shape_profile(true, t)[:, 0] + 0.7 * drdh
    got = drift_term.choose_shape(t, y, drdh, 60.0)
    assert got == true


def test_peak_to_peak_and_its_error_by_the_delta_method():
    shape = {"kind": "dip", "start": 4.0, "length": 3.0}
    a, se = drift_term.peak_to_peak(shape, (0.0, 12.0), np.array([-0.12]), np.array([[0.01 ** 2]]))
    assert a == pytest.approx(0.12, rel=1e-3) and se == pytest.approx(0.01, rel=1e-3)


def test_blind_windows_are_the_holds_where_no_plausible_drift_shows():
    t = np.arange(0.0, 20.0, 1 / 30)
    accel = (t > 5.0) & (t < 9.0)                     # a speed change: ∂r/∂h large
    drdh = np.where(accel, 20.0, 0.5) + 0.1 * np.sin(3.0 * t)
    wins = drift_term.blind_windows(t, drdh, floor_rms=0.2, tau_int=10.0, min_t=4.0, dh_max=0.25)
    assert wins, "the holds must be reported blind"
    for a, b in wins:     # no window reaches into the speed change beyond a dip's flat edge
        assert b <= 5.5 + 1e-9 or a >= 8.5 - 1e-9
    assert any(a <= 10.0 and b >= 19.0 for a, b in wins)     # the hold after it
    # a recording that is all speed changes has no blind window
    assert drift_term.blind_windows(t, np.full(t.size, 20.0), 0.2, 10.0, 4.0, 0.25) == []
