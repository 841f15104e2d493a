"""Wheels by name (the shipped wheels.csv) and a spec the log contradicts (euc_sim.rides.source.spec)."""

from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from euc_sim.cli import main
from euc_sim.rides.drive.battery import cell_figures
from euc_sim.rides.source.sanity import input_warnings
from euc_sim.rides.source.spec import (SpecError, WheelSpec, find_wheel, known_wheels, log_contradictions,
                                       read_spec, wheel_spec)

#: The shared rides beside the repository (the nearest ancestor holding them: a checkout or a worktree).
DATA = next((p / "shared" / "data" / "euc_core" for p in Path(__file__).resolve().parents
             if (p / "shared" / "data" / "euc_core").is_dir()), Path("shared/data/euc_core"))
SHARED = ("v9", "lynx", "apex", "aero", "blitz", "mten4", "master pro v2", "s22 pro", "z10")


@pytest.mark.parametrize("name, full", [("v9", "InMotion V9"), ("V9", "InMotion V9"), ("inmotion v9", "InMotion V9"),
                                        ("InMotion-V9", "InMotion V9"), ("master_pro_V2", "Begode Master Pro V2"),
                                        ("Begode Master Pro V2", "Begode Master Pro V2"), ("KS S22 Pro", "KingSong S22 Pro"),
                                        ("segway z10", "Ninebot Z10"), ("veteran lynx", "Leaperkim Lynx")])
def test_a_wheel_by_name_or_alias(name, full):
    spec = wheel_spec(name)
    assert spec.name == full and spec == find_wheel(name)
    assert spec.source.startswith("euc-sim's wheel table") and "EUC_core" in spec.source


def test_every_shared_wheel_ships_with_its_figures_and_source():
    assert set(SHARED) <= set(known_wheels())
    for name in SHARED:
        s = find_wheel(name)
        assert s.missing == () and s.series and s.parallel and s.top_speed and s.motor_power, name
        assert s.battery_voltage == pytest.approx(4.2 * s.series), name          # full charge, 4.2 V a cell
        cell = cell_figures(s.cell)
        assert cell is not None and cell.capacity_mAh, name
        # the pack's energy is its cells' (3.6 V nominal) within 15 %: no figure mistyped
        cells_Wh = s.series * s.parallel * 3.6 * cell.capacity_mAh / 1000
        assert s.energy_Wh == pytest.approx(cells_Wh, rel=0.15), name


def test_a_path_still_works_and_reads_the_new_fields(tmp_path):
    f = tmp_path / "w.csv"
    f.write_text("Field|Data\nBrand| B\nModel| M\nNet weight| 30 kg\nTension| 134.4 V\n"
                 "Max speed| 122 km/h (150km/h Race mode)\nBattery architecture| 32s4p\n"
                 "Cells| SAMSUNG 50S (21700) li-ion\nMotor power| 3500 W\nBattery| 2400 Wh\n")
    s = wheel_spec(str(f))
    assert (s.name, s.series, s.parallel, s.motor_power, s.energy_Wh) == ("B M", 32, 4, 3500.0, 2400.0)
    assert s.top_speed == pytest.approx(122 / 3.6)
    f.write_text("Field|Data\nNet weight| 30 kg\nMotor power| 2x1500 W\nBattery| 20 Ah\n")
    assert (read_spec(f).motor_power, read_spec(f).energy_Wh) == (None, None)   # optional: left unknown
    f.write_text("Field|Data\nNet weight| 30 kg\nBattery architecture| 32 cells\n")
    with pytest.raises(SpecError, match="Battery architecture.*20s2p"):
        read_spec(f)


def _fails(argv, match, capsys):
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(match, err), err
    return err


def test_an_unknown_name_lists_the_known_ones_and_exits_2(tmp_path, capsys):
    err = _fails(["ride", tmp_path / "log.csv", "--wheel", "v10", "--no-simulate"], r"no such wheel", capsys)
    assert all(n in err for n in SHARED)
    _fails(["ride", tmp_path / "log.csv", "--wheel", "specs/v10.csv"], r"specs/v10.csv: no such file", capsys)
    _fails(["rides", tmp_path, "--wheel", "hoverboard"], r"no such wheel.*v9, lynx", capsys)


def _data(volts, kmh=30.0):
    v = np.asarray(volts, float)
    return pd.DataFrame({"voltage": v, "v": np.full(v.size, kmh / 3.6)})


def test_the_log_against_its_spec():
    v9 = find_wheel("v9")                                          # 20 cells: 50-85 V over a ride
    assert log_contradictions(v9, _data(np.linspace(70, 83, 500))) == []
    low = log_contradictions(v9, _data(np.linspace(45, 83, 500)))         # sags below 2.5 V a cell
    assert len(low) == 1 and "outside" in low[0] and "50-85 V" in low[0]
    fast = log_contradictions(v9, _data(np.linspace(70, 83, 500), kmh=60.0))   # 45 km/h wheel at 60
    assert len(fast) == 1 and "60 km/h" in fast[0] and "45 km/h" in fast[0]
    assert log_contradictions(v9, _data(np.linspace(70, 83, 500), kmh=50.0)) == []   # within 15 %
    with pytest.raises(SpecError, match="cannot be the spec's Begode Blitz pack"):      # a V9 log, a Blitz spec
        log_contradictions(find_wheel("blitz"), _data(np.linspace(70, 83, 500)))
    with pytest.raises(SpecError, match="cannot be"):           # an 84 V spec, a 16-cell log at 60-67 V
        log_contradictions(WheelSpec(battery_voltage=84.0), _data(np.linspace(60, 67, 500)))
    with pytest.raises(SpecError, match="cannot be"):           # a 100 V log on an 84 V spec
        log_contradictions(v9, _data(np.linspace(90, 100, 500)))


def test_a_tyre_off_by_more_than_its_tolerance_is_named():
    log = SimpleNamespace(path="r.csv", data=_data(np.linspace(70, 83, 500)))
    v9 = find_wheel("v9")
    assert input_warnings(log, v9, SimpleNamespace(estimate=0.89, sd=0.015, source="gps")) == []   # reads 12 % high
    slow = input_warnings(log, v9, SimpleNamespace(estimate=1.12, sd=0.01, source="gps"))       # reads 11 % low
    assert len(slow) == 1 and "tyre" in slow[0] and "16 inches" in slow[0]
    assert input_warnings(log, v9, SimpleNamespace(estimate=1.12, sd=0.05, source="gps")) == []  # could be within
    assert "cannot be" in input_warnings(log, find_wheel("blitz"), SimpleNamespace(estimate=1.0, sd=0.01,
                                                                                    source="gps"))[0]


@pytest.mark.skipif(not DATA.is_dir(), reason=f"{DATA} absent (user's clone)")
def test_a_v9_log_with_the_blitz_spec_is_refused(tmp_path, capsys):
    log = DATA / "trips" / "inmotion" / "v9" / "0" / "0.csv"
    for wheel in (DATA / "specs" / "blitz.csv", "blitz"):
        err = _fails(["ride", log, "--wheel", wheel, "--no-simulate", "--json", tmp_path / "o.json"],
                     r"0\.csv: the log's battery voltage \(72-82 V\) cannot be the spec's Begode Blitz pack", capsys)
        assert "--wheel" in err
    assert not (tmp_path / "o.json").exists()


@pytest.mark.skipif(not DATA.is_dir(), reason=f"{DATA} absent (user's clone)")
def test_the_shipped_specs_agree_with_the_shared_rides():
    from euc_sim.rides.source.logs import read_log

    for log in sorted(DATA.glob("trips/*/*/*/*.csv")):
        if log.name == "meta.csv":
            continue
        wheel = pd.read_csv(log.parent / "meta.csv")["wheel"][0]
        data = read_log(log, emit_warnings=False).data
        assert log_contradictions(find_wheel(wheel), data) == [], log
        assert log_contradictions(read_spec(DATA / "specs" / f"{wheel}.csv"), data) == [], log
