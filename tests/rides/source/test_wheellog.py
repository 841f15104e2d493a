"""Tests of euc_sim.rides.source.logs on small logs written here (both WheelLog layouts,
EUC World, DarknessBot, malformed files) and, where ../shared is present, on the
two real rides."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from euc_sim.rides.source.logs import LogFormatError, RideLogWarning, read_log

SHARED = Path(__file__).resolve().parents[4] / "shared" / "data" / "wheellog"

OLD = ("date,time,speed,voltage,current,power,battery_level,distance,totaldistance,"
       "system_temp,cpu_temp,tilt,roll,mode,alert")
NEW = ("date,time,latitude,longitude,gps_speed,gps_alt,gps_heading,gps_distance,speed,voltage,"
       "phase_current,current,power,torque,pwm,battery_level,distance,totaldistance,"
       "system_temp,temp2,tilt,roll,mode,alert")


def write(tmp_path: Path, text: str, name: str = "log.csv") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def old_rows(times, speeds, tilt="0.00"):
    return "\n".join(f"2020-05-16,{t},{s:.2f},64.00,2.00,128.00,90,0,1000,27,0,{tilt},{tilt},0,"
                     for t, s in zip(times, speeds))


@pytest.fixture
def old_log(tmp_path):
    times = ["08:02:10.000", "08:02:10.200", "08:02:10.450", "08:02:10.600", "08:02:10.800"]
    return write(tmp_path, OLD + "\n" + old_rows(times, [0.0, 3.6, 7.2, 10.8, 14.4]) + "\n")


def new_row(t, speed, lat="53.92", gps_speed="18.0", alt="259.5", tilt="2.50", mode="Drive"):
    return (f"2025-01-29,{t},{lat},27.45,{gps_speed},{alt},90.0,12,{speed},83.28,12.00,5.00,"
            f"416.40,3.50,44.06,95,1,4778555,24,30,{tilt},-1.30,{mode},")


# --- the two WheelLog layouts ---------------------------------------------------------
def test_old_layout_units_and_time(old_log):
    log = read_log(old_log, emit_warnings=False)
    assert (log.layout, log.variant) == ("wheellog", "old")
    assert np.allclose(log.data["t"], [0.0, 0.2, 0.45, 0.6, 0.8])
    assert np.allclose(log.data["v"], [0.0, 1.0, 2.0, 3.0, 4.0])          # km/h -> m/s
    assert np.allclose(log.data["power"], 128.0)
    assert str(log.start) == "2020-05-16 08:02:10"


def test_all_zero_tilt_roll_reported_absent(old_log):
    log = read_log(old_log, emit_warnings=False)
    assert "tilt" in log.absent and "roll" in log.absent
    assert not log.has("tilt") and "tilt" not in log.data
    assert any(w.startswith("tilt: all 5 values are zero") for w in log.warnings)


def test_warnings_are_issued(old_log):
    with pytest.warns(RideLogWarning, match="tilt: all 5 values are zero"):
        read_log(old_log)


def test_new_layout_by_name_with_gps_and_phase_current(tmp_path):
    rows = [new_row("23:05:53.800", "14.40"), new_row("23:05:54.000", "18.00"),
            new_row("23:05:54.200", "21.60", tilt="0.00")]
    log = read_log(write(tmp_path, NEW + "\n" + "\n".join(rows) + "\n"), emit_warnings=False)
    assert (log.layout, log.variant) == ("wheellog", "new")
    d = log.data
    assert np.allclose(d["v"], [4.0, 5.0, 6.0])
    assert np.allclose(d["gps_speed"], 5.0)                                 # km/h -> m/s
    assert np.allclose(d["gps_alt"], 259.5)
    assert np.allclose(d["phase_current"], 12.0) and np.allclose(d["current"], 5.0)
    assert d["tilt"].iloc[0] == pytest.approx(2.5 * math.pi / 180)        # degrees -> rad
    assert d["gps_heading"].iloc[0] == pytest.approx(math.pi / 2)
    assert "tilt" not in log.absent                                        # not all zero


def test_column_order_does_not_matter(tmp_path):
    rows = [new_row("23:05:53.800", "14.40"), new_row("23:05:54.000", "18.00")]
    cols = NEW.split(",")
    perm = list(reversed(range(len(cols))))
    text = ",".join(cols[i] for i in perm) + "\n" + "\n".join(
        ",".join(r.split(",")[i] for i in perm) for r in rows) + "\n"
    a = read_log(write(tmp_path, NEW + "\n" + "\n".join(rows) + "\n", "a.csv"), emit_warnings=False)
    b = read_log(write(tmp_path, text, "b.csv"), emit_warnings=False)
    assert list(a.data.columns) != [] and set(a.data.columns) == set(b.data.columns)
    for c in a.data.columns:
        assert np.allclose(a.data[c], b.data[c], equal_nan=True)


def test_empty_gps_fields_kept_as_nan_and_counted(tmp_path):
    rows = [new_row("23:05:53.800", "14.40", lat="", gps_speed="", alt=""),
            new_row("23:05:54.000", "18.00"), new_row("23:05:54.200", "21.60")]
    log = read_log(write(tmp_path, NEW + "\n" + "\n".join(rows) + "\n"), emit_warnings=False)
    assert np.isnan(log.data["gps_alt"].iloc[0]) and log.data["gps_alt"].iloc[1] == 259.5
    assert "gps_alt: 1 of 3 cells empty (kept as NaN)" in log.warnings
    assert len(log.data) == 3                                              # nothing dropped


def test_all_empty_gps_is_absent(tmp_path):
    rows = [new_row(f"23:05:5{i}.000", "10.00", lat="", gps_speed="", alt="") for i in range(3)]
    log = read_log(write(tmp_path, NEW + "\n" + "\n".join(rows) + "\n"), emit_warnings=False)
    assert {"latitude", "gps_speed", "gps_alt"} <= set(log.absent)
    assert "gps_alt: all 3 cells empty; treated as absent" in log.warnings


def test_repeated_timestamps_averaged_and_counted(tmp_path):
    times = ["08:02:10.000", "08:02:10.200", "08:02:10.200", "08:02:10.200", "08:02:10.400",
             "08:02:10.400", "08:02:10.600"]
    speeds = [3.6, 7.2, 10.8, 14.4, 18.0, 21.6, 25.2]
    log = read_log(write(tmp_path, OLD + "\n" + old_rows(times, speeds) + "\n"), emit_warnings=False)
    assert np.allclose(log.data["t"], [0.0, 0.2, 0.4, 0.6])
    assert np.allclose(log.data["v"], [1.0, 3.0, 5.5, 7.0])                # averages
    assert log.n_rows_merged == 3 and log.n_rows_read == 7
    assert any("2 time stamp(s) shared by 5 rows" in w and "3 rows merged" in w
               for w in log.warnings)


def test_backward_time_sorted_and_counted(tmp_path):
    times = ["08:02:10.000", "08:02:10.400", "08:02:10.200", "08:02:10.600"]
    log = read_log(write(tmp_path, OLD + "\n" + old_rows(times, [0, 3.6, 7.2, 10.8]) + "\n"),
                   emit_warnings=False)
    assert np.all(np.diff(log.data["t"]) > 0)
    assert np.allclose(log.data["v"], [0.0, 2.0, 1.0, 3.0])
    assert any("time ran backwards at 1 row(s)" in w for w in log.warnings)


def test_irregular_sampling_summarised(tmp_path):
    times = ["08:02:10.000", "08:02:10.200", "08:02:10.205", "08:02:12.000"]
    log = read_log(write(tmp_path, OLD + "\n" + old_rows(times, [0, 1, 2, 3]) + "\n"),
                   emit_warnings=False)
    w = [x for x in log.warnings if x.startswith("irregular sampling")]
    assert len(w) == 1
    assert "1 gap(s) longer than 1 s" in w[0] and "1 interval(s) shorter than 20 ms" in w[0]


def test_midnight_rollover_uses_date(tmp_path):
    text = (OLD + "\n2020-05-16,23:59:59.900,3.60,64,1,64,90,0,1,27,0,0,0,0,\n"
            "2020-05-17,00:00:00.100,3.60,64,1,64,90,0,1,27,0,0,0,0,\n")
    log = read_log(write(tmp_path, text), emit_warnings=False)
    assert log.data["t"].iloc[1] == pytest.approx(0.2)


def test_truncated_last_line_dropped_loudly(tmp_path):
    text = OLD + "\n" + old_rows(["08:02:10.000", "08:02:10.200"], [3.6, 7.2]) + "\n2020-05-16,08:02:1\n"
    log = read_log(write(tmp_path, text), emit_warnings=False)
    assert len(log.data) == 2
    assert any("dropped the truncated last line 4" in w for w in log.warnings)


# --- malformed files ----------------------------------------------------------------------
def test_missing_speed_column(tmp_path):
    p = write(tmp_path, "date,time,voltage\n2020-05-16,08:02:10.000,64\n")
    with pytest.raises(ValueError, match=r"log\.csv: column 'speed'.*missing required column"):
        read_log(p)


def test_missing_time_column(tmp_path):
    p = write(tmp_path, "date,speed,voltage\n2020-05-16,10,64\n")
    with pytest.raises(LogFormatError, match=r"column 'time': missing required column"):
        read_log(p)


def test_unrecognised_file(tmp_path):
    p = write(tmp_path, "a,b\n1,2\n")
    with pytest.raises(ValueError, match=r"column 'speed'.*not a recognised EUC log"):
        read_log(p)


def test_non_numeric_value_names_column_and_line(tmp_path):
    text = OLD + "\n" + old_rows(["08:02:10.000"], [3.6]) + "\n" + \
        "2020-05-16,08:02:10.200,fast,64.00,2.00,128.00,90,0,1000,27,0,0,0,0,\n"
    with pytest.raises(ValueError, match=r"log\.csv: column 'speed', line 3: expected a number, "
                                         r"got 'fast'"):
        read_log(write(tmp_path, text))


def test_non_numeric_optional_value_is_an_error_too(tmp_path):
    text = OLD + "\n2020-05-16,08:02:10.000,3.60,64.00,n/a,128.00,90,0,1000,27,0,0,0,0,\n"
    with pytest.raises(ValueError, match=r"column 'current', line 2: expected a number, got 'n/a'"):
        read_log(write(tmp_path, text))


def test_empty_required_cell_mid_file(tmp_path):
    text = OLD + "\n" + old_rows(["08:02:10.000"], [3.6]) + "\n" + \
        "2020-05-16,08:02:10.200,,64.00,2.00,128.00,90,0,1000,27,0,0,0,0,\n" + \
        old_rows(["08:02:10.400"], [3.6]) + "\n"
    with pytest.raises(ValueError, match=r"column 'speed', line 3: empty cell in a required column"):
        read_log(write(tmp_path, text))


def test_bad_timestamp(tmp_path):
    text = OLD + "\n" + old_rows(["08:02:10.000"], [3.6]) + "\n" + old_rows(["25:99:10.200"], [3.6]) + "\n"
    with pytest.raises(ValueError, match=r"column 'date\+time', line 3: cannot read the time stamp"):
        read_log(write(tmp_path, text))


def test_empty_file(tmp_path):
    with pytest.raises(ValueError, match=r"log\.csv: empty file"):
        read_log(write(tmp_path, ""))


def test_header_only(tmp_path):
    with pytest.raises(ValueError, match=r"log\.csv: header only, no data rows"):
        read_log(write(tmp_path, OLD + "\n"))


def test_too_many_fields(tmp_path):
    text = OLD + "\n" + old_rows(["08:02:10.000"], [3.6]) + ",extra,more\n"
    with pytest.raises(ValueError, match=r"log\.csv: line 2: 17 fields, but the header has 15"):
        read_log(write(tmp_path, text))


@pytest.mark.parametrize("quoted", [False, True])
def test_too_many_fields_named_on_their_line_whether_or_not_a_field_is_quoted(tmp_path, quoted):
    rows = old_rows(["08:02:10.000", "08:02:10.200", "08:02:10.400"], [3.6, 3.7, 3.8]).split("\n")
    rows[0] += ",,"                                     # empty extra fields: not data, accepted
    rows[2] += ',"a, b"' if quoted else ",x"            # a comma inside quotes is one field
    with pytest.raises(ValueError, match=r"log\.csv: line 4: 16 fields, but the header has 15"):
        read_log(write(tmp_path, OLD + "\n" + "\n".join(rows) + "\n"))


def test_missing_file_is_oserror(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.csv"):
        read_log(tmp_path / "nope.csv")


def test_forced_layout_checks_columns(tmp_path):
    p = write(tmp_path, "Date,Speed\n2024-01-01T10:00:00,10\n")
    with pytest.raises(LogFormatError, match="column 'date'"):
        read_log(p, layout="wheellog")


# --- other apps' layouts (from third-party parsers; see the module docstring) -------------
def test_eucworld_layout(tmp_path):
    text = ("datetime,speed,voltage,current,current_phase,power,safety_margin,battery,distance,"
            "distance_total,temp,tilt,roll,gps_lat,gps_lon,gps_speed,gps_alt,gps_bearing,"
            "gps_distance\n"
            "2024-05-01 10:00:00.000,18.0,84.0,5.0,20.0,420.0,30,80,1.5,1234.5,35,1.0,0.5,"
            "50.1,19.9,17.0,210.0,45.0,1.4\n"
            "2024-05-01 10:00:00.250,21.6,84.0,6.0,22.0,504.0,31,80,1.505,1234.505,35,1.0,0.5,"
            "50.1,19.9,20.0,210.5,45.0,1.405\n")
    log = read_log(write(tmp_path, text), emit_warnings=False)
    assert log.layout == "eucworld"
    assert np.allclose(log.data["v"], [5.0, 6.0])
    assert np.allclose(log.data["distance"], [1500.0, 1505.0])             # km -> m
    assert np.allclose(log.data["phase_current"], [20.0, 22.0])
    assert np.allclose(log.data["t"], [0.0, 0.25])


def test_darknessbot_layout_both_date_forms(tmp_path):
    head = ("Date,Speed,Voltage,PWM,Current,Power,Battery level,Total mileage,Temperature,"
            "Pitch,Roll,Latitude,Longitude,Altitude\n")
    for name, stamps in [("iso.csv", ["2025-05-30T20:17:22.000000", "2025-05-30T20:17:22.500000"]),
                         ("dmy.csv", ["30.05.2025 20:17:22.000", "30.05.2025 20:17:22.500"])]:
        text = head + "".join(f"{s},{sp},121.8,,8.7,1055.9,67.0,1000.5,27.0,,,69.65,18.91,50.7\n"
                              for s, sp in zip(stamps, ["0.0", "36.0"]))
        log = read_log(write(tmp_path, text, name), emit_warnings=False)
        assert log.layout == "darknessbot"
        assert np.allclose(log.data["t"], [0.0, 0.5])
        assert np.allclose(log.data["v"], [0.0, 10.0])
        assert np.allclose(log.data["total_distance"], 1000500.0)
        assert "pwm" in log.absent and "tilt" in log.absent


# --- the real rides -------------------------------------------------------------------------
@pytest.mark.skipif(not SHARED.is_dir(), reason=f"{SHARED} absent (user's clone)")
@pytest.mark.parametrize("name, rows, duration, vmax_kmh", [
    ("2020_05_16_08_02_06.csv", 1660, 336.05, 23.12),
    ("2020_05_28_07_52_00.csv", 1573, 317.78, 23.86),
])
def test_real_rides(name, rows, duration, vmax_kmh):
    log = read_log(SHARED / name, emit_warnings=False)
    assert (log.layout, log.variant) == ("wheellog", "old")
    assert log.n_rows_read == rows
    assert log.duration == pytest.approx(duration, abs=0.01)
    assert log.data["v"].max() == pytest.approx(vmax_kmh / 3.6)
    assert {"tilt", "roll"} <= set(log.absent)
    # exact repeats: none in these files; near-repeats (< 20 ms) are counted instead
    assert log.n_rows_merged == 0
    assert any("shorter than 20 ms" in w for w in log.warnings)
    p = log.data
    assert np.allclose(p["power"], p["voltage"] * p["current"], atol=0.01)
