"""The naming test, its false-name control and the smallest difference it names with 80 % power: its calibration,
the column through the model, and a synthetic pair where the prediction is checked both ways."""

import numpy as np
import pytest

from euc_sim.rides.compare import differences_fit as pf
from euc_sim.rides.compare import resolution as rs
from euc_sim.report.ride.contract import differences_json
from test_differences_fit import _design, _power, _ride


def test_the_named_size_is_where_the_score_test_names_with_80_percent_power():
    """Blocks' held-out scores drawn as the power model says (a difference Δ adds Δ·S_b to each
    block's noise X_b): at the named size the two-sided test names 80 % of them."""
    rng = np.random.default_rng(0)
    B = 40
    S = rng.uniform(0.5, 2.0, B) * 1e4
    sd = 30.0 * np.sqrt(S) * rng.uniform(0.5, 2.0, B)
    for level in (0.05, 0.05 / 6):
        d = rs.named_size(S, sd, level=level)
        noise = sd * rng.standard_normal((4000, B))
        p = np.array([rs.score_test(d * S + x, x)[0] for x in noise])
        assert np.mean(p < level) == pytest.approx(0.8, abs=0.03)
        # without the difference the test names at its level
        null = np.array([rs.score_test(x, sd * rng.standard_normal(B))[0] for x in noise])
        assert np.mean(null < level) == pytest.approx(level, abs=0.012)
    assert rs.named_size(S, sd, level=0.05 / 6) > rs.named_size(S, sd, level=0.05)
    assert rs.named_size(0 * S, sd, level=0.05) is None


def test_a_ride_against_itself_is_never_significant_and_the_delays_test_is_one_sided():
    zero = np.zeros(12)
    assert rs.score_test(zero, zero)[0] == 1.0
    w = np.array([100.0, 120.0, 90.0, 110.0, 105.0, 98.0])
    assert rs.paired_test(w, w)[0] == 1.0
    lower = w * np.array([1.1, 1.12, 1.08, 1.1, 1.09, 1.11])
    p, mean, _ = rs.paired_test(w, lower)
    assert p < 0.001 and mean > 0
    assert rs.paired_test(lower, w)[0] > 0.999


def test_benjamini_hochberg_against_a_hand_computed_answer():
    p = [0.01, 0.04, 0.03, 0.005, 0.2, 0.5]
    # sorted 0.005 0.01 0.03 0.04 0.2 0.5 → ×6/rank: 0.03 0.03 0.06 0.06 0.24 0.5, then the running
    # minimum from the top: 0.03 0.03 0.06 0.06 0.24 0.5
    assert rs.bh_qvalues(p) == pytest.approx([0.03, 0.06, 0.06, 0.03, 0.24, 0.5])
    assert rs.bh_qvalues([0.02, 0.021, 0.9]) == pytest.approx([0.0315, 0.0315, 0.9])
    assert rs.bh_qvalues([0.9, 0.95]) == pytest.approx([0.95, 0.95])
    assert len(rs.bh_qvalues([])) == 0


def test_the_larger_of_the_interval_and_the_test():
    blocks = (np.full(20, 1e4), np.full(20, 1e3))
    wide = rs.detectable_difference("x", (-3.0, 5.0), 40.0, 500.0, blocks=blocks)
    assert wide.interval_halfwidth == pytest.approx(4.0) and wide.resolvable == pytest.approx(4.0)
    narrow = rs.detectable_difference("x", (0.99, 1.01), 40.0, 500.0, blocks=blocks)
    assert narrow.resolvable == pytest.approx(narrow.gate) and narrow.gate > 0.01
    shift = rs.with_floor(rs.detectable_difference("d", (0.3, 0.5)), 0.2)
    assert shift.gate is None and shift.resolvable == pytest.approx(0.3) and shift.floor == pytest.approx(0.2)
    assert rs.detectable_difference("x", None).resolvable is None


def test_the_column_through_the_model_is_what_the_other_columns_leave():
    rng = np.random.default_rng(0)
    t = np.arange(3000) / 10.0
    a, b = rng.standard_normal(3000), rng.standard_normal(3000)
    nil = np.zeros(3000)
    # columns: shared (a on LOG, b on OTHER), OTHER's own (b), the difference (2b + noise), y
    ZL = np.column_stack([a, nil, nil, a])
    ZO = np.column_stack([b, b, 2.0 * b + 0.5 * rng.standard_normal(3000), b])
    (GL,), fL, _ = pf.block_grams(t, [ZL])
    (GO,), fO, nO = pf.block_grams(t, [ZO])
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
    null = pf.pair_fit(_drag_pair(0.0), n_boot=60, seed=0)
    assert null.selected == []
    r = null.resolutions["aerodynamic_drag"].resolvable
    assert r > 0
    for factor, named in ((3.0, True), (1.0 / 3.0, False)):
        fit = pf.pair_fit(_drag_pair(factor * r), n_boot=60, seed=0)
        lo, hi = fit.estimates["aerodynamic_drag"][1]
        assert (fit.p_values["aerodynamic_drag"] < 0.05 and (lo > 0 or hi < 0)) == named
        assert (fit.p_values["aerodynamic_drag"] < 0.001) == named
        res = fit.resolutions["aerodynamic_drag"]
        assert res.resolvable == pytest.approx(r, rel=0.2)     # the pair's noise, not the effect
        gain = rs.predicted_gain(factor * r, res.residual_rms, res.signature_rms,
                                 res.interval_halfwidth / rs.Z95, 5)
        assert gain == pytest.approx(fit.gains["aerodynamic_drag"], abs=0.002)


def test_the_json_and_the_page_carry_the_pairs_resolution():
    from euc_sim.rides.compare import differences as df
    from euc_sim.report.ride.differences_page import difference_lines

    det = {"total_mass": rs.detectable_difference("total_mass", (-2.0, 28.0), 60.0, 1.5,
                                                  blocks=(np.full(20, 4.0), np.full(20, 14.0))),
           "rolling_resistance": rs.detectable_difference("rolling_resistance", (0.004, 0.016), 60.0, 9000.0,
                                                          blocks=(np.full(20, 4e9), np.full(20, 3e6)))}
    tested = {"total_mass": df.Tested(13.0, (-2.0, 28.0), 0.004, detectable=det["total_mass"]),
              "rolling_resistance": df.Tested(0.01, (0.004, 0.016), 0.002, detectable=det["rolling_resistance"])}
    typed = df.ride_differences([], [], tested, {}, {}, "x")
    res = differences_json(typed)
    by = {d["name"]: d for d in res["differences"]}
    assert by["total_mass"]["resolvable"] == pytest.approx(det["total_mass"].resolvable)
    assert by["total_mass"]["resolution"]["gate"] == pytest.approx(det["total_mass"].gate)
    mass = det["total_mass"].resolvable
    assert mass > 13.0                                     # the estimate lies below what the pair resolves
    lines = difference_lines(typed, "b.csv")
    assert lines[0].endswith(f"This pair cannot resolve differences smaller than mass ±{mass:.0f} kg: "
                             "its estimate lies below that, so whether the rides differ by it cannot be said.")
    # rolling's estimate lies above what the pair resolves: said as what the pair could have seen
    assert f"could have seen: rolling resistance ±{100 * det['rolling_resistance'].resolvable:.1f} %" in lines[0]


def test_a_difference_of_the_rides_own_fits_that_the_pair_does_not_name_is_explained():
    """The tiles give each ride's own resistance; where those differ and the paired test names
    nothing, the differences block says both, so the page does not contradict itself."""
    from dataclasses import replace

    from euc_sim.rides.compare.differences import Difference, Differences
    from euc_sim.report.ride.differences_page import difference_lines

    entry = Difference("internal_resistance", 0.0146, (-0.015, 0.044), "ohm", False,
                       "not significant on the compared ride's held-out blocks (p = 0.021, q = 0.11 after the "
                       "false-name control across the tested physics, level 5 %)",
                       independent=(0.0146, (0.0042, 0.024)), detectable=rs.Resolution("internal_resistance", 0.068, None))
    lines = difference_lines(Differences((entry,)), "b.csv")
    said = [ln for ln in lines if "each ride's own fit (the key figures) differs" in ln]
    assert len(said) == 1 and "+15 mΩ (95 % interval +4 to +24 mΩ)" in said[0] and "q = 0.11" in said[0]
    overlapping = replace(entry, independent=(0.0146, (-0.002, 0.03)))
    lines = difference_lines(Differences((overlapping,)), "b.csv")
    said = [ln for ln in lines if "each ride's own fit" in ln]     # the tiles' difference, not the test's size
    assert len(said) == 1 and "+15 mΩ (95 % interval −2 to +30 mΩ): cannot tell" in said[0]
    assert not any("resistance ±" in ln for ln in lines)
