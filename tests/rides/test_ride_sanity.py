"""Issue 20, items 4 and 5: two rides compared, and bad input that never gives a confident
absurd mass (an absurd spec: one line, exit 2; a log in other units: a warning, or the mass
withheld with the suspicion named)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pandas as pd
import pytest
from drivesynth import drive_log

from euc_sim.cli.app import main
from euc_sim.rides.grids.power import SpeedScale
from euc_sim.rides.source.sanity import TOTAL_MASS_RANGE, input_warnings, mass_suspicion
from euc_sim.rides.source.spec import SpecError, WheelSpec, read_spec, wheel_spec
from euc_sim.rides.source.systematic import combined_interval, mass_difference


def _spec(tmp_path, weight="23.5 kg", tension="84 V", diameter="16 inches"):
    p = tmp_path / "spec.csv"
    p.write_text(f"Field|Data\nBrand| X\nModel| Y\nWheel diameter| {diameter}\n"
                 f"Net weight| {weight}\nTension| {tension}\n")
    return p


@pytest.mark.parametrize("field, kw, want", [
    ("Net weight", {"weight": "2350 kg"}, "2350 kg is no electric unicycle's wheel mass"),
    ("Tension", {"tension": "8400 V"}, "8400 V is no electric unicycle's battery voltage"),
    ("Wheel diameter", {"diameter": "160 inches"}, "160 inches"),
])
def test_an_absurd_spec_is_refused_in_one_line_naming_the_field(tmp_path, capsys, field, kw, want):
    spec = _spec(tmp_path, **kw)
    with pytest.raises(SpecError, match=f"field '{field}'"):
        read_spec(spec)
    log = drive_log(tmp_path / "ok.csv", seed=1, duration=60.0)
    out = tmp_path / "out.json"
    code = main(["ride", str(log), "--wheel", str(spec), "--no-simulate", "--n-boot", "10",
                 "--json", str(out)])
    err = [ln for ln in capsys.readouterr().err.splitlines()
           if ln.strip() and not ln.startswith("ride: ")]
    assert code == 2 and len(err) == 1 and want in err[0], err
    assert not out.exists()


def test_an_absurd_override_is_refused():
    from euc_sim.rides.request import ride_request

    with pytest.raises(ValueError, match=r"--wheel-mass: expected a number in \[5, 100\] kg, got 0.5"):
        ride_request("absent.csv", wheel_mass=0.5)
    with pytest.raises(ValueError, match=r"--radius: expected a number in \[0.1, 0.4\] m, got -3"):
        ride_request("absent.csv", radius=-3.0)
    assert wheel_spec(wheel_mass=23.5).wheel_mass == 23.5


def test_an_absurd_mass_is_withheld_with_the_suspicion():
    lo, hi = TOTAL_MASS_RANGE
    assert mass_suspicion(110.0) is None and mass_suspicion(None) is None
    assert "mA read as A" in mass_suspicion(1000.0 * 110.0)
    assert "mph read as km/h" in mass_suspicion(2.6 * 110.0 + hi)
    assert mass_suspicion(lo - 1.0) is not None


def test_a_log_in_mph_or_against_another_wheels_voltage_is_named(tmp_path):
    from euc_sim.rides.source.logs import read_log

    path = drive_log(tmp_path / "mph.csv", seed=2, duration=400.0)
    df = pd.read_csv(path)
    df["speed"] = (df["speed"] / 1.609344).round(2)          # mph written where km/h is read
    df.to_csv(path, index=False)
    from euc_sim.rides.grids.power import speed_scale

    log = read_log(path, emit_warnings=False)
    k = speed_scale(log)
    assert k.estimate > 1.4                                   # GPS rescales it ...
    warn = input_warnings(log, WheelSpec(battery_voltage=84.0), k)
    assert len(warn) == 1 and "mph read as km/h" in warn[0]   # ... and the page says why
    warn = input_warnings(log, WheelSpec(battery_voltage=151.2, source="s.csv"), k)
    assert any("another wheel's" in w for w in warn)


def _fit(est, lo, hi, sys_, source="gps"):
    return SimpleNamespace(estimate=est, stat_ci95=(lo, hi), systematic=sys_,
                           scale=SpeedScale(1.0, 0.01, source))


def test_mass_difference_verdicts_and_shared_parts_cancel():
    sys_ = {"current_scale": 20.0, "rotating_share": 2.0, "speed_scale": 2.0, "grade": 1.0}
    a = _fit(100.0, 95.0, 105.0, sys_)
    d = mass_difference(a, _fit(125.0, 120.0, 130.0, sys_))
    assert d.verdict == "heavier" and d.unit == "kg" and d.estimate == pytest.approx(25.0)
    # the wheel's current scale (20 kg) cancels: the half-width is √(5² + 5² + 2·(2² + 1²))
    assert d.ci95[0] == pytest.approx(25.0 - (50 + 10) ** 0.5)
    assert mass_difference(a, _fit(80.0, 75.0, 85.0, sys_)).verdict == "lighter"
    assert mass_difference(a, _fit(103.0, 98.0, 108.0, sys_)).verdict == "cannot tell"
    none = mass_difference(a, SimpleNamespace(estimate=None, stat_ci95=None, systematic={},
                                              scale=SpeedScale(1.0, 0.05, "assumed")))
    assert none.estimate is None and none.verdict == "cannot tell" and none.why


def test_the_interval_adds_systematic_parts_in_quadrature_and_holds_the_estimate():
    assert combined_interval(100.0, (90.0, 104.0), {}) == pytest.approx((90.0, 104.0))
    lo, hi = combined_interval(100.0, (90.0, 104.0), {"a": 6.0, "b": 8.0})
    assert lo == pytest.approx(100.0 - (100 + 100) ** 0.5) and hi == pytest.approx(100.0 + (16 + 100) ** 0.5)
    lo, hi = combined_interval(100.0, (101.0, 110.0), {})          # a median outside the pool
    assert lo <= 100.0 <= hi


def test_compare_reports_the_mass_difference(tmp_path, capsys):
    a = drive_log(tmp_path / "a.csv", seed=3, duration=300.0)
    b = drive_log(tmp_path / "b.csv", seed=4, duration=300.0)
    out = tmp_path / "o.json"
    assert main(["ride", str(a), "--compare", str(b), "--wheel-mass", "20", "--no-simulate",
                 "--n-boot", "20", "--json", str(out), "--quiet"]) == 0
    d = json.loads(out.read_text())["mass_difference"]
    assert d["unit"] == "kg" and d["verdict"] in ("heavier", "lighter", "cannot tell")
    assert d["ci95"][0] <= d["estimate"] <= d["ci95"][1]
    assert d["ci95"][0] <= 0.0 <= d["ci95"][1] and d["verdict"] == "cannot tell"   # same truth


def test_the_spec_radius_and_the_found_mass_reach_the_balance_fit():
    from euc_sim.rides.grids.signals import RideAssumptions
    from euc_sim.rides.grids.signals import with_found_values

    a = with_found_values(RideAssumptions(), WheelSpec(radius=0.254, name="Blitz"), 115.0, 122.0)
    assert (a.R, a.total_mass, a.m_eq) == (0.254, 115.0, 122.0)
    assert a.source_of("R").startswith("spec (Blitz") and a.source_of("total_mass").startswith("found")
    given = RideAssumptions(R=0.22, sources=(("R", "--radius"),))
    b = with_found_values(given, WheelSpec(radius=0.254), None)
    assert b.R == 0.22 and b.source_of("R") == "--radius"
    assert b.total_mass == RideAssumptions().total_mass and b.source_of("total_mass") == "default (Table 3)"
