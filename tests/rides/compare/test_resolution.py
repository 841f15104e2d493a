"""The smallest difference a pair can name, predicted from the pair's own noise: the gate's algebra,
the column through the model, and a synthetic pair where the prediction is checked both ways."""

import numpy as np
import pytest

from euc_sim.rides.compare import differences_fit as pf
from euc_sim.rides.compare import resolution as rs
from test_differences_fit import _design, _power, _ride


def test_the_gate_size_is_where_the_predicted_gain_reaches_the_threshold():
    sigma, s = 40.0, 500.0
    for se in (0.0, 0.004):
        d = rs.gate_size(sigma, s, se, 0.01, 5)
        assert rs.predicted_gain(d, sigma, s, se, 5) == pytest.approx(0.01, rel=1e-9)
        assert rs.predicted_gain(1.5 * d, sigma, s, se, 5) > 0.01 > rs.predicted_gain(0.7 * d, sigma, s, se, 5)
    # no estimation cost: b = 0.1425 σ, i.e. removing RMS b lowers the RMS by about b²/(2σ²)
    assert rs.gate_factor(0.01) == pytest.approx(0.1425, abs=5e-4)
    assert rs.gate_size(sigma, s, 0.0, 0.01, 5) * s / sigma == pytest.approx(rs.gate_factor(0.01))
    assert rs.gate_size(sigma, 0.0, 0.0, 0.01, 5) is None


def test_the_larger_of_the_interval_and_the_gate():
    wide = rs.detectable_difference("x", (-3.0, 5.0), 40.0, 500.0, min_gain=0.01)
    assert wide.interval_halfwidth == pytest.approx(4.0) and wide.resolvable == pytest.approx(4.0)
    narrow = rs.detectable_difference("x", (0.99, 1.01), 40.0, 500.0, min_gain=0.01)
    assert narrow.resolvable == pytest.approx(narrow.gate) and narrow.gate > 0.01
    shift = rs.with_floor(rs.detectable_difference("d", (0.3, 0.5), min_gain=0.01), 0.2)
    assert shift.gate is None and shift.resolvable == pytest.approx(0.3) and shift.floor == pytest.approx(0.2)
    assert rs.detectable_difference("x", None, min_gain=0.01).resolvable is None


def test_the_column_through_the_model_is_what_the_other_columns_leave():
    rng = np.random.default_rng(0)
    t = np.arange(3000) / 10.0
    a, b = rng.standard_normal(3000), rng.standard_normal(3000)
    nil = np.zeros(3000)
    # columns: shared (a on LOG, b on OTHER), OTHER's own (b), the difference (2b + noise), y
    ZL = np.column_stack([a, nil, nil, a])
    ZO = np.column_stack([b, b, 2.0 * b + 0.5 * rng.standard_normal(3000), b])
    GL, fL, _ = pf.block_grams(t, ZL)
    GO, fO, nO = pf.block_grams(t, ZO)
    alone = rs.heldout_signature_rms(GL, fL, GO, fO, nO, [], 2)
    assert alone == pytest.approx(np.sqrt(np.mean(ZO[:, 2] ** 2)), rel=1e-9)
    # a shared column fitted on both rides takes about half of 2b (LOG's rows pull it to zero): √(1 + 0.25)
    assert rs.heldout_signature_rms(GL, fL, GO, fO, nO, [0], 2) == pytest.approx(np.sqrt(1.25), rel=0.05)
    # OTHER's own column takes all of it: the noise is left
    assert rs.heldout_signature_rms(GL, fL, GO, fO, nO, [1], 2) == pytest.approx(0.5, rel=0.05)


def _drag_pair(dk):
    log, other = _ride(1), _ride(2)
    return _design(log, other, _power(log[1], log[2], seed=1), _power(other[1], other[2], k=0.3 + dk, seed=2))


def test_a_difference_well_above_its_predicted_resolution_is_named_and_well_below_is_not():
    null = pf.pair_fit(_drag_pair(0.0), min_gain=0.01, n_boot=60, seed=0)
    assert null.selected == []
    r = null.resolutions["aerodynamic_drag"].resolvable
    assert r > 0
    for factor, named in ((3.0, True), (1.0 / 3.0, False)):
        fit = pf.pair_fit(_drag_pair(factor * r), min_gain=0.01, n_boot=60, seed=0)
        lo, hi = fit.estimates["aerodynamic_drag"][1]
        assert ("aerodynamic_drag" in fit.selected and (lo > 0 or hi < 0)) == named
        res = fit.resolutions["aerodynamic_drag"]
        assert res.resolvable == pytest.approx(r, rel=0.2)     # the pair's noise, not the effect
        gain = rs.predicted_gain(factor * r, res.residual_rms, res.signature_rms,
                                 res.interval_halfwidth / rs.Z95, 5)
        assert gain == pytest.approx(fit.gains["aerodynamic_drag"], abs=0.002)
        assert 0.0 < res.gain_se < 0.5 * max(gain, 0.01)     # the fold spread: well inside the gate here


def test_the_json_and_the_page_carry_the_pairs_resolution():
    from euc_sim.rides.compare import differences as df
    from euc_sim.rides.report.differences_page import difference_lines

    det = {"total_mass": rs.detectable_difference("total_mass", (-2.0, 28.0), 60.0, 1.5, min_gain=0.01),
           "rolling_resistance": rs.detectable_difference("rolling_resistance", (0.004, 0.016), 60.0, 9000.0,
                                                          min_gain=0.01)}
    tested = {"total_mass": {"estimate": 13.0, "ci95": (-2.0, 28.0), "heldout_gain": 0.004, "selected": False,
                             "detectable": det["total_mass"]},
              "rolling_resistance": {"estimate": 0.01, "ci95": (0.004, 0.016), "heldout_gain": 0.002,
                                     "selected": False, "detectable": det["rolling_resistance"]}}
    res = df.ride_differences([], [], tested, {}, {}, "x").to_json()
    by = {d["name"]: d for d in res["differences"]}
    assert by["total_mass"]["resolvable"] == pytest.approx(det["total_mass"].resolvable)
    assert by["total_mass"]["resolution"]["gate"] == pytest.approx(det["total_mass"].gate)
    mass = det["total_mass"].resolvable
    assert mass > 13.0                                     # the estimate lies below what the pair resolves
    lines = difference_lines({"compare": "b.csv", **res})
    assert lines[0].endswith(f"This pair cannot resolve differences smaller than mass ±{mass:.0f} kg: "
                             "its estimate lies below that, so whether the rides differ by it cannot be said.")
    # rolling's estimate lies above what the pair resolves: said as what the pair could have seen
    assert f"could have seen: rolling resistance ±{100 * det['rolling_resistance'].resolvable:.1f} %" in lines[0]
