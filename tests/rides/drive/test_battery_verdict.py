"""The battery's verdict in a rider's words: a new pack's resistance from its layout and cells,
the thresholds on the ride's interval, the trend across rides (euc_sim.rides.drive.battery)."""

from __future__ import annotations

import warnings

import pytest

from euc_sim.rides.drive.battery import (AGED_RATIO, PackSpec, battery_health, cell_figures, health_verdict,
                                         pack_spec, trend_words)
from euc_sim.report.ride.contract import battery_json
from euc_sim.rides.source.spec import find_wheel


def test_a_new_packs_resistance_from_its_layout_and_cells():
    fig = cell_figures("SAMSUNG 50S (21700) li-ion")
    assert fig.cell == "Samsung INR21700-50S" and fig.dc_ohm == pytest.approx(14.2e-3) and "tayvoy" in fig.source
    assert "50G" in cell_figures("SAMSUNG 50GB (21700)").cell and "50E" in cell_figures("Samsung 50E").cell
    assert cell_figures("Panasonic NCR18650B") is None
    (lo, hi), src = PackSpec(series=36, parallel=4, cell="Samsung 50S").expected()
    assert lo == pytest.approx(36 * (14.2e-3 / 4 + 0.2e-3) + 5e-3)          # cells at mid-charge + allowance
    assert hi == pytest.approx(36 * (1.4 * 14.2e-3 / 4 + 1.0e-3) + 30e-3)
    assert "36s4p" in src and "INR21700-50S" in src and "allowance" in src
    # twice the cells in parallel: half the cells' part
    (lo2, _), _ = PackSpec(series=36, parallel=8, cell="Samsung 50S").expected()
    assert lo2 - (36 * 0.2e-3 + 5e-3) == pytest.approx((lo - (36 * 0.2e-3 + 5e-3)) / 2)
    none, why = PackSpec(series=14, parallel=6, cell="LG MH1 (18650)").expected()
    assert none is None and "no resistance figure" in why and "MH1" in why
    assert PackSpec(cell="Samsung 50S").expected()[0] is None                  # no layout
    assert pack_spec(find_wheel("v9")).expected()[0] is not None


@pytest.mark.parametrize("r, ci, verdict, clause", [
    (0.25, (0.24, 0.26), "as new", "overlaps"),
    (0.30, (0.28, 0.31), "as new", "overlaps"),                # reaching just past the range: overlaps
    (0.15, (0.14, 0.16), "as new", "lies below"),
    (0.36, (0.33, 0.39), "worn: +20 % resistance", "lies above"),
    (0.60, (0.50, 0.70), "worn: +100 % resistance", "lies above"),
    (0.30, (0.20, 0.40), "cannot tell", "too wide"),           # overlaps, but reaches past 1.3 × 0.3
])
def test_verdict_thresholds_on_synthetic_intervals(r, ci, verdict, clause):
    v, why = health_verdict(r, ci, (0.2, 0.3))
    assert v == verdict and clause in why and "200–300 mΩ" in why
    assert AGED_RATIO == 1.3


def test_no_expected_range_cannot_tell_and_says_why():
    h = battery_health(0.05, (0.04, 0.06), None, pack_spec(find_wheel("z10")))
    assert h.verdict == "cannot tell" and "no resistance figure for the cell LG INR18650MH1" in h.verdict_why
    assert h.expected_ohm is None and h.expected_source is None
    assert battery_health(0.2, (0.19, 0.21)).verdict_why == "no wheel specification given"


def test_the_verdict_reads_the_25C_value():
    pack = pack_spec(find_wheel("v9"))
    (lo, hi), _ = pack.expected()
    # as measured inside the range, but at 5 °C: its 25 °C value is far lower, below the range
    cold = battery_health(hi * 0.95, (hi * 0.9, hi * 0.99), 5.0, pack)
    assert cold.resistance_25C_ci95[1] < lo and "lies below" in cold.verdict_why
    j = battery_json(cold)
    assert j["verdict"] == "as new" and j["expected_ohm"] == [pytest.approx(lo), pytest.approx(hi)]
    assert "20s2p" in j["expected_source"] and "50G" in j["expected_source"]


def test_trend_words():
    assert trend_words([0.20, 0.21, 0.205], [(0.19, 0.21), (0.2, 0.22), (0.195, 0.215)]) == \
        "resistance unchanged across 3 rides"
    assert trend_words([0.20, 0.21, 0.224], [(0.19, 0.21), (0.2, 0.22), (0.215, 0.233)]) == \
        "rising: +12 % from first to last"
    assert trend_words([0.20, 0.18], [(0.195, 0.205), (0.175, 0.185)]) == "falling: −10 % from first to last"


def test_summary_battery_carries_the_contract_keys(tmp_path):
    from euc_sim.report.ride.contract import rider_json
    from euc_sim.rides.summary.rider_view import rider_numbers
    from euc_sim.rides.source.logs import read_log
    from tests.rides.summarysynth import synth_summary_log

    log = read_log(synth_summary_log(tmp_path / "a.csv"), emit_warnings=False)
    from euc_sim.rides.drive.drivetrain import Term

    rep = {"drivetrain": {"internal_resistance": Term(0.4, (0.38, 0.42), "ohm")}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = rider_json(rider_numbers(log, None, rep["drivetrain"], find_wheel("v9")))
    sb = out["summary"]["battery"]
    assert set(sb) == {"verdict", "expected_ohm", "expected_source"}
    assert sb["verdict"].startswith("worn: +") and len(sb["expected_ohm"]) == 2
    assert out["battery"]["verdict"] == sb["verdict"]
