"""Battery internal resistance: the drivetrain's number, normalised to 25 °C, judged against a spec."""

from __future__ import annotations

import math
import warnings

import pytest

from euc_sim.rides.drive.battery import (PackSpec, battery_health, battery_health_of,
                                   measure_resistance, pack_spec, to_25C)
from euc_sim.rides.drive.drivetrain import Term
from euc_sim.report.ride.contract import battery_json
from euc_sim.rides.source.spec import read_spec
from euc_sim.rides.source.logs import read_log
from tests.rides.summarysynth import synth_summary_log


def _log(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_log(path, emit_warnings=False)


def test_measured_resistance_recovers_the_synthetic_sag(tmp_path):
    log = _log(synth_summary_log(tmp_path / "a.csv", R_int=0.15, amps_wave=0.8, ocv_per_Ah=1.5,
                                 amps=20.0))
    r, ci = measure_resistance(log, n_boot=30, seed=1)
    assert r == pytest.approx(0.15, rel=0.02)
    assert ci[0] < ci[1] and ci[0] == pytest.approx(0.15, rel=0.02) and ci[1] == pytest.approx(0.15, rel=0.02)


def test_to_25C_is_arrhenius_and_identity_at_25():
    assert to_25C(0.2, 25.0) == pytest.approx(0.2)
    warm, cold = to_25C(0.2, 35.0), to_25C(0.2, 15.0)
    assert warm > 0.2 > cold          # a warm pack reads low: its 25 °C value is higher
    assert math.log(warm / 0.2) == pytest.approx(20000 / 8.314462618 * (1 / 298.15 - 1 / 308.15), rel=1e-9)


def test_pack_spec_reads_architecture_and_cell_resistance(tmp_path):
    f = tmp_path / "w.csv"
    f.write_text("Field|Data\nNet weight| 20 kg\nBattery| 750 Wh\nBattery architecture| 20s2p\n"
                 "Cells| X (21700)\nCell resistance| 15 mOhm\n")
    p = pack_spec(read_spec(f))
    assert (p.series, p.parallel, p.energy_Wh, p.cell_resistance_ohm) == (20, 2, 750.0, pytest.approx(0.015))
    (lo, hi), src = p.expected()
    assert (lo, hi) == (pytest.approx(0.150 + 20 * 0.2e-3 + 5e-3), pytest.approx(0.210 + 20 * 1e-3 + 30e-3))
    assert "20s2p" in src
    assert pack_spec(None) is None


def test_verdicts():
    pack = PackSpec(series=20, parallel=2, cell="c", cell_resistance_ohm=0.015)
    (lo, hi), _ = pack.expected()
    assert battery_health(0.16, (0.15, 0.17), None, pack).verdict == "as new"
    assert battery_health(0.4, (0.38, 0.42), None, pack).verdict.startswith("worn: +")
    h = battery_health(0.16, (0.15, 0.17), 35.0, pack)
    assert h.resistance_25C_ohm == pytest.approx(to_25C(0.16, 35.0))
    assert h.per_cell_ohm == pytest.approx(0.016)
    assert battery_json(h)["expected_ohm"] == [pytest.approx(lo), pytest.approx(hi)]
    assert battery_health(0.16, (0.15, 0.17)).verdict == "cannot tell"
    app = battery_health(0.16, None, wheel_reported_ohm=0.13)
    assert app.expected_ohm is None and app.app_setting_ohm == 0.13      # a setting, not a spec
    assert app.verdict == "cannot tell" and "130 mΩ" in app.sentence
    assert battery_health(None, None, why="no current").verdict == "not measured"


def test_from_report_reads_the_drivetrain_term_not_a_second_fit():
    h = battery_health_of(Term(0.2, (0.19, 0.21), "ohm"))
    assert h.resistance_ohm == 0.2 and h.resistance_ci95 == (0.19, 0.21)
    assert battery_json(h)["resistance_ci95"] == [0.19, 0.21]
    assert battery_health_of(None).verdict == "not measured"
    assert battery_health_of(Term(None, None, None, why="no current")).verdict == "not measured"
