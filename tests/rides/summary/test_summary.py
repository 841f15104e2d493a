"""The ride summary on synthetic logs with known answers, and against the real logs' own counters."""

from __future__ import annotations

import warnings
from pathlib import Path

import pandas as pd
import pytest

from euc_sim.report.ride.contract import summary_json
from euc_sim.rides.summary.summary import BRIDGE_S, Gaps, mass_check, ride_summary
from euc_sim.rides.source.logs import read_log
from tests.rides.summarysynth import as_layout, synth_summary_log

#: ../shared/data beside the clone (or beside the folder of worktrees)
DATA = next((p / "shared" / "data" for p in Path(__file__).resolve().parents[4:6]
             if (p / "shared" / "data").is_dir()), Path("/nonexistent"))


def _summary(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        log = read_log(path, emit_warnings=False)
    return ride_summary(log)


def test_known_ride(tmp_path):
    s = _summary(synth_summary_log(tmp_path / "a.csv"))
    assert s.duration_s == pytest.approx(620.0, abs=0.3)        # first turn of the wheel to the end
    assert s.logged_s == pytest.approx(640.0, abs=0.01)
    assert s.moving_s == pytest.approx(600.0, abs=0.5)
    assert s.distance_source == "gps"
    assert s.distance_m == pytest.approx(25 / 3.6 * 600, rel=0.005)
    assert s.speed_max_mps == pytest.approx(25 / 3.6, rel=1e-6)
    # 80 V × 10 A for 600 s = 133.3 Wh, plus 80 V × 0.2 A at rest for 40 s
    assert s.energy_drawn_Wh == pytest.approx(80 * 10 * 600 / 3600 + 80 * 0.2 * 40 / 3600, rel=0.005)
    assert s.energy_regen_Wh is None          # the current is never negative: not signed
    assert s.Wh_per_km == pytest.approx(s.energy_drawn_Wh / (s.distance_m / 1000), rel=0.01)
    assert s.pwm_max_pct == pytest.approx(72.5) and s.pwm_max_at_s == pytest.approx(300.0, abs=0.2)
    assert s.safety_margin_min_pct == pytest.approx(27.5)
    assert s.pwm_max_place["lat"] > 48.0
    assert s.gaps == Gaps(count=0, total_s=0.0, longest_s=0.0, limit_s=1.0)
    assert s.quality == "good"


def test_battery_used_is_read_at_rest_not_under_sag(tmp_path):
    # sag 0.5 %/A at 10 A would read 5 points more used if taken under load
    s = _summary(synth_summary_log(tmp_path / "a.csv", battery=(90.0, 60.0), sag_pct_per_amp=0.5))
    assert s.battery_start_pct == pytest.approx(90.0, abs=0.2)
    assert s.battery_end_pct == pytest.approx(60.0, abs=0.2)
    assert s.battery_used_pct == pytest.approx(30.0, abs=0.4)
    assert s.range_m_at_this_rate == pytest.approx(s.distance_m * 100 / s.battery_used_pct)


def test_regen_is_counted_apart(tmp_path):
    s = _summary(synth_summary_log(tmp_path / "a.csv", regen_amps=5.0))
    assert s.energy_regen_Wh == pytest.approx(80 * 5 * 60 / 3600, rel=0.02)
    assert s.energy_drawn_Wh == pytest.approx(80 * 10 * 540 / 3600 + 80 * 0.2 * 40 / 3600, rel=0.01)
    net = s.energy_drawn_Wh - s.energy_regen_Wh
    assert s.Wh_per_km == pytest.approx(net / (s.distance_m / 1000), rel=0.01)


def test_gap_is_not_integrated_across_and_lowers_quality(tmp_path):
    s = _summary(synth_summary_log(tmp_path / "a.csv", gps=False, gap=(200.0, 150.0)))
    assert s.gaps.count == 1 and s.gaps.longest_s == pytest.approx(150.2, abs=0.3)
    assert s.quality == "poor"                   # 150 s of 640 s missing
    assert s.distance_source == "wheel"
    # the distance still comes from the wheel's trip counter across the gap ...
    assert s.distance_m == pytest.approx(25 / 3.6 * 600, rel=0.005)
    # ... but the energy leaves the gap out, and so does the distance Wh/km divides it by
    assert s.energy_drawn_Wh == pytest.approx(80 * 10 * (600 - 150) / 3600 + 80 * 0.2 * 40 / 3600, rel=0.01)
    assert s.Wh_per_km == pytest.approx(80 * 10 / (25 / 3.6) / 3.6, rel=0.03)
    assert s.speed_mean_moving_mps == pytest.approx(25 / 3.6, rel=0.01)   # over the same stretch
    assert 150.0 > BRIDGE_S


def test_alarms_are_episodes(tmp_path):
    s = _summary(synth_summary_log(tmp_path / "a.csv", alarm_rows=(500, 501, 502, 900)))
    assert s.alarms == 2 and s.alarm_rows == 4


def test_absent_channels_give_null(tmp_path):
    path = tmp_path / "old.csv"
    path.write_text("date,time,speed,voltage,current,power,battery_level,distance,totaldistance,"
                    "system_temp,cpu_temp,tilt,roll,mode,alert\n"
                    + "".join(f"2024-06-01,10:00:{i // 5:02d}.{(i % 5) * 200:03d},{10 if 5 < i < 250 else 0},"
                              f"80,5,400,80,0,0,30,30,0,0,0,\n" for i in range(290)))
    s = _summary(path)
    assert s.pwm_max_pct is None and s.pwm_max_at_s is None and s.distance_source == "wheel"
    assert s.battery_used_pct == 0.0 and s.range_m_at_this_rate is None
    js = summary_json(s)
    assert set(js) >= {"duration_s", "moving_s", "distance_m", "distance_source", "speed_max_mps",
                       "speed_mean_moving_mps", "energy_drawn_Wh", "energy_regen_Wh", "Wh_per_km",
                       "battery_used_pct", "range_m_at_this_rate", "pwm_max_pct", "pwm_max_at_s",
                       "alarms", "gaps"}


def _with_spin(path):
    """The log at ``path`` with the wheel lifted and spun up in the last stop (0 → 120 km/h in
    0.6 s at 100 % PWM, held 1 s, then coasting down at 0.8 g)."""
    import numpy as np
    import pandas as pd

    df = pd.read_csv(path, dtype=str, keep_default_na=False)
    t = (pd.to_datetime(df["date"] + " " + df["time"]) - pd.Timestamp("2024-06-01 10:00:00")).dt.total_seconds()
    up = np.clip((t - 625.0) / 0.6, 0, 1) * 120.0
    down = np.clip(120.0 - 0.8 * 9.81 * 3.6 * (t - 626.6), 0, None)
    v = np.where((t >= 625.0) & (t < 626.6), up, np.where(t >= 626.6, down, 0.0))
    spin = (t >= 625.0) & (v > 0)
    df["speed"], df["pwm"] = df["speed"].astype(float), df["pwm"].astype(float)
    df.loc[spin, "speed"] = np.round(v[spin], 2)
    df.loc[spin & (t < 626.6), "pwm"] = 100.0
    df.to_csv(path, index=False)
    return path


def test_a_free_spin_is_not_the_rides_top_speed_or_pwm(tmp_path):
    """A wheel lifted and spun (apex/0: 0 → 122 km/h in 0.8 s at a stop, 100 % PWM) is said
    apart, not taken as the ride's top speed or its PWM peak."""
    s = _summary(_with_spin(synth_summary_log(tmp_path / "a.csv")))
    assert s.speed_max_mps == pytest.approx(25 / 3.6, rel=1e-6)
    assert s.pwm_max_pct == pytest.approx(72.5) and s.pwm_max_at_s == pytest.approx(300.0, abs=0.2)
    assert s.free_spin.count == 1 and s.free_spin.speed_max_mps == pytest.approx(120 / 3.6, rel=0.01)
    assert 625.4 <= s.free_spin.at_s <= 626.6 and s.free_spin.total_s == pytest.approx(5.6, abs=0.3)  # until 9 km/h
    assert "speed_max_mps" in s.why
    assert _summary(synth_summary_log(tmp_path / "b.csv")).free_spin is None


def test_mass_check_verdicts():
    from types import SimpleNamespace

    tm = SimpleNamespace(estimate=110.0, ci95=(100.0, 120.0), why=None)
    assert mass_check(tm, 85.0, 25.0).verdict == "consistent"
    heavier = mass_check(tm, 60.0, 25.0)
    assert heavier.verdict == "heavier" and heavier.difference_kg == pytest.approx(25.0)
    assert heavier.difference_ci95 == pytest.approx((15.0, 35.0))
    assert "25 kg more" in heavier.sentence
    assert mass_check(tm, 100.0, 25.0).verdict == "lighter"
    assert mass_check(SimpleNamespace(estimate=None, ci95=None, why="x"), 80.0, 25.0).verdict == "cannot tell"
    assert mass_check(tm, 80.0, None).verdict == "cannot tell"


RIDES = sorted(DATA.glob("euc_core/trips/*/*/*/[0-9]*.csv"))


@pytest.mark.skipif(not RIDES, reason="the shared real rides (../shared/data/euc_core) are absent")
@pytest.mark.parametrize("path", RIDES, ids=lambda p: "/".join(p.parts[-3:-1]))
def test_real_ride_agrees_with_its_own_counters(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        log = read_log(path, emit_warnings=False)
    c = log.counters
    s = ride_summary(log)
    # the counter the page follows, read from the CSV the way a rider reads the app: its rise
    raw = pd.read_csv(path, usecols=lambda n: n in ("distance", "gps_distance"))
    col = {"the app's GPS distance": "gps_distance", "the wheel's trip counter": "distance"}[s.distance_follows]
    x = raw[col].dropna().to_numpy()
    assert s.distance_m == pytest.approx((x[-1] - x[0]) * (1000.0 if log.layout == "eucworld" else 1.0), rel=0.02)
    if c.duration_s is not None:                  # EUC World's trip and riding clocks
        assert s.duration_follows == "the app's trip and riding clocks"
        assert s.duration_s == pytest.approx(c.duration_s, rel=0.02)
        assert s.moving_s == pytest.approx(c.moving_s, rel=0.02)
    spin = s.free_spin            # the app's top speed and the logged PWM count the wheel off the ground
    if c.speed_max_mps is not None:
        top = max(s.speed_max_mps, spin.speed_max_mps) if spin else s.speed_max_mps
        assert top == pytest.approx(c.speed_max_mps, rel=0.05)
    assert s.energy_drawn_Wh == pytest.approx(c.power_Wh_drawn, rel=0.05)
    if "pwm" in log.data:
        logged = float(log.data["pwm"].max())
        assert s.pwm_max_pct <= logged and (spin is not None or s.pwm_max_pct == pytest.approx(logged, abs=1.5))
    assert s.battery_used_pct == pytest.approx(c.battery_start_pct - c.battery_end_pct, abs=2.0)


@pytest.mark.parametrize("layout", ["eucworld", "darknessbot"])
def test_other_layouts_give_the_same_summary(tmp_path, layout):
    from tests.rides.summarysynth import as_layout

    src = synth_summary_log(tmp_path / "a.csv", alarm_rows=(500, 501, 900), regen_amps=5.0)
    ref = _summary(src)
    s = _summary(as_layout(src, tmp_path / f"{layout}.csv", layout))
    for name in ("duration_s", "moving_s", "distance_m", "speed_max_mps", "energy_drawn_Wh",
                 "energy_regen_Wh", "battery_used_pct", "pwm_max_pct"):
        assert getattr(s, name) == pytest.approx(getattr(ref, name), rel=0.01, abs=0.05), name
    assert s.distance_source == "gps"
    assert s.alarms == (2 if layout == "eucworld" else None)    # DarknessBot writes no alarm column


def test_rider_numbers_reads_the_reports_terms(tmp_path):
    from euc_sim.report.ride.contract import rider_json
    from euc_sim.rides.summary.rider_view import rider_numbers
    from euc_sim.rides.source.spec import WheelSpec

    path = synth_summary_log(tmp_path / "a.csv")
    from types import SimpleNamespace

    from euc_sim.rides.drive.drivetrain import Term

    rep = {"total_mass": SimpleNamespace(estimate=100.0, ci95=(90.0, 110.0), why=None),
           "drivetrain": {"internal_resistance": Term(0.2, (0.19, 0.21), "ohm")}}
    log = read_log(path, emit_warnings=False)
    out = rider_json(rider_numbers(log, rep["total_mass"], rep["drivetrain"], WheelSpec(wheel_mass=25.0), 90.0))
    assert out["summary"]["distance_m"] == pytest.approx(25 / 3.6 * 600, rel=0.005)
    assert out["mass_check"]["verdict"] == "lighter" and out["mass_check"]["difference_kg"] == pytest.approx(-15.0)
    assert "15 kg less than declared" in out["mass_check"]["sentence"]
    assert out["battery"]["resistance_ohm"] == 0.2
    assert summary_json(rider_numbers(log, rep["total_mass"], rep["drivetrain"]).summary) == summary_json(rider_numbers(
        log, rep["total_mass"], rep["drivetrain"], WheelSpec(wheel_mass=25.0), 90.0).summary)


def test_a_pause_of_the_log_does_not_make_its_data_poor(tmp_path):
    """S22 Pro 0 was 'poor: 1.7 samples/s, 49 gap(s) ... (20 % of the log, longest 1517.3 s)',
    a 25-minute pause (left out of the duration) counted as lost rows."""
    s = _summary(synth_summary_log(tmp_path / "a.csv", ride_s=1800.0, gap=(900.0, 600.0)))
    assert s.gaps.longest_s == pytest.approx(600.2, abs=0.01)          # the JSON's gaps keep it
    assert s.quality == "good" and s.sampling_hz == pytest.approx(5.0, rel=0.01)
    assert s.quality_sentence == ("Data quality good: 5.0 samples/s, no gap longer than 1 s; 1 pause(s) of "
                                  "the log over 5 min (10 min) left out.")
    lost = _summary(synth_summary_log(tmp_path / "b.csv", ride_s=1800.0, gap=(900.0, 290.0)))
    assert lost.quality == "fair" and "1 gap(s) longer than 1 s, 290 s in all" in lost.quality_sentence


def test_quality_is_judged_against_what_the_app_normally_writes(tmp_path):
    """EUC World writes in bursts up to 1.7 s apart (InMotion V9): bursts 1.4 s apart are its
    normal and read good; the same rows from a fixed-rate app (WheelLog) are gappy."""
    import pandas as pd
    src = synth_summary_log(tmp_path / "wl.csv", rate=5.0, ride_s=1200.0)
    df = pd.read_csv(src, dtype=str, keep_default_na=False)
    df[(pd.RangeIndex(len(df)) % 12) < 6].to_csv(src, index=False)     # 6 rows, then a 1.4 s hole
    wl = _summary(src)
    ew = _summary(as_layout(src, tmp_path / "ew.csv", "eucworld"))
    assert ew.sampling_hz == pytest.approx(2.5, rel=0.01) and ew.gaps.limit_s == 2.0
    assert ew.gaps.count == 0 and ew.quality == "good"
    assert "no gap longer than 2 s" in ew.quality_sentence
    assert wl.gaps.limit_s == 1.0 and wl.quality == "poor"


# -- the app's own counters -------------------------------------------------------------
RIDE_M = 25 / 3.6 * 600                     # the synthetic ride's distance, m


def _eucworld_with_counters(tmp_path, *, gap=None, clock0=0.0, trip0_km=0.0, gps_scale=0.95):
    """The synthetic ride in EUC World's layout with its trip clocks (from the wheel's first turn,
    ``clock0`` s already run before the log) and its GPS distance (``gps_scale`` × the wheel's),
    the trip counters starting at ``trip0_km``; ``gap`` = (t, length) rows missing, the app's
    counters running on."""
    import numpy as np
    import pandas as pd

    ew = as_layout(synth_summary_log(tmp_path / "a.csv"), tmp_path / "ew.csv", "eucworld")
    df = pd.read_csv(ew, dtype=str, keep_default_na=False)
    t = (pd.to_datetime(df["datetime"].str[:23]) - pd.Timestamp("2024-06-01 10:00:00")).dt.total_seconds()
    km = pd.to_numeric(df["distance"])
    df["duration"] = np.floor(clock0 + (t - 20.0).clip(lower=0)).astype(int)
    df["duration_riding"] = np.floor(clock0 + (t - 20.0).clip(0, 600)).astype(int)
    df["distance"] = (trip0_km + km).round(3)
    df["gps_distance"] = (trip0_km + gps_scale * km).round(3)
    if gap is not None:
        df = df[(t < gap[0]) | (t >= gap[0] + gap[1])]
    df.to_csv(ew, index=False)
    return ew


def test_eucworld_follows_the_apps_gps_distance_and_trip_clock_across_a_gap(tmp_path):
    """A minute of rows missing while riding (the app's counters run on), a log started 59 s
    and 0.3 km into its trip: the page says what the app says, and which counter it follows."""
    s = _summary(_eucworld_with_counters(tmp_path, gap=(200.0, 60.0), clock0=59.0, trip0_km=0.3))
    assert s.distance_source == "gps" and s.distance_follows == "the app's GPS distance"
    assert s.distance_m == pytest.approx(300.0 + 0.95 * RIDE_M, abs=2.0)
    assert s.distance_wheel_m == pytest.approx(300.0 + RIDE_M, abs=2.0)           # the trip counter
    assert s.duration_s == 59 + 620 and s.moving_s == 59 + 600
    assert s.duration_follows == "the app's trip and riding clocks"
    # energy and Wh/km still leave the gap out
    assert s.Wh_per_km == pytest.approx(80 * 10 / (25 / 3.6) / 3.6 / 0.95, rel=0.03)


def test_eucworld_gps_counter_missing_part_of_the_ride_is_not_followed(tmp_path):
    """An app's GPS distance that misses a third of the ride is not the ride's distance."""
    import pandas as pd

    src = _eucworld_with_counters(tmp_path)
    df = pd.read_csv(src, dtype=str, keep_default_na=False)
    df.loc[: len(df) // 3, "gps_distance"] = ""
    df.to_csv(src, index=False)
    s = _summary(src)
    assert s.distance_follows.startswith("the GPS track (the app's GPS distance covers")
    assert s.distance_m == pytest.approx(RIDE_M, rel=0.005)


def _wheellog_lagging_counter(path, gap=(200.0, 60.0)):
    """WheelLog with rows missing while riding, its trip counter read one row late after the gap."""
    import numpy as np
    import pandas as pd

    synth_summary_log(path, gps=False, gap=gap)
    df = pd.read_csv(path, dtype=str, keep_default_na=False)
    t = (pd.to_datetime(df["date"] + " " + df["time"]) - pd.Timestamp("2024-06-01 10:00:00")).dt.total_seconds()
    after = int(np.flatnonzero(t.to_numpy() >= gap[0] + gap[1])[0])
    df.loc[after, ["distance", "totaldistance"]] = df.loc[after - 1, ["distance", "totaldistance"]].to_numpy()
    df.to_csv(path, index=False)
    return path


def test_wheellog_follows_its_trip_counter_read_late_after_a_gap(tmp_path):
    s = _summary(_wheellog_lagging_counter(tmp_path / "a.csv"))
    assert s.distance_source == "wheel" and s.distance_follows == "the wheel's trip counter"
    assert s.distance_m == pytest.approx(RIDE_M, abs=2.0)
    assert s.duration_follows == "the wheel's first turn to the last row"


def test_wheellog_counter_readings_out_of_order_count_once(tmp_path):
    """A counter alternating between two readings a few metres apart (as a WheelLog log does):
    its rise is last minus first, not the sum of its rises."""
    import numpy as np
    import pandas as pd

    path = synth_summary_log(tmp_path / "a.csv", gps=False)
    df = pd.read_csv(path, dtype=str, keep_default_na=False)
    x = pd.to_numeric(df["distance"]).to_numpy()
    odd = (np.arange(x.size) % 2 == 1) & (x > 1000) & (x < 1300)
    df.loc[odd, "distance"] = (x[odd] - 3).astype(int).astype(str)
    df.to_csv(path, index=False)
    s = _summary(path)
    assert s.distance_m == pytest.approx(RIDE_M, abs=2.0)


def test_without_a_counter_the_speed_is_integrated_over_the_gaps_the_wheel_rode(tmp_path):
    """The older WheelLog layout with its distance columns zero: half a minute of rows missing
    at 25 km/h is ridden distance."""
    import pandas as pd

    path = synth_summary_log(tmp_path / "a.csv", gps=False, gap=(200.0, 30.0))
    df = pd.read_csv(path, dtype=str, keep_default_na=False)
    df["distance"] = df["totaldistance"] = "0"
    df.to_csv(path, index=False)
    s = _summary(path)
    assert s.distance_m == pytest.approx(RIDE_M, rel=0.002)
    assert s.distance_follows == "the wheel's speed integrated, gaps up to 60 s bridged"


def test_an_odometer_disagreeing_with_the_speed_is_followed_and_said(tmp_path):
    """DarknessBot: an odometer 4 % above the integrated speed (a tyre smaller than the wheel
    assumes) is the wheel's own count; one in the wrong unit is not."""
    import pandas as pd

    src = synth_summary_log(tmp_path / "a.csv", gps=False, gap=(200.0, 45.0))
    for name, scale, follows in (("odo", 1.04, "the wheel's odometer"),
                                 ("miles", 1.04 / 1.609, "the wheel's speed integrated")):
        db = as_layout(src, tmp_path / f"{name}.csv", "darknessbot")
        df = pd.read_csv(db, dtype=str, keep_default_na=False)
        m = pd.to_numeric(df["Total mileage"]) - 100.0
        df["Total mileage"] = (100.0 + scale * m).round(4)
        df.to_csv(db, index=False)
        s = _summary(db)
        assert s.distance_follows.startswith(follows), s.distance_follows
        want = 1.04 * RIDE_M if scale == 1.04 else RIDE_M
        assert s.distance_m == pytest.approx(want, rel=0.005), name


def test_darknessbot_gps_track_fills_its_holes_from_the_wheels_counter(tmp_path):
    s = _summary(as_layout(synth_summary_log(tmp_path / "a.csv", gap=(200.0, 60.0)),
                           tmp_path / "db.csv", "darknessbot"))
    assert s.distance_source == "gps" and s.distance_follows == "the GPS track"
    assert s.distance_m == pytest.approx(RIDE_M, rel=0.005)


def test_a_gps_distance_repeating_its_reading_through_a_lost_fix_is_followed(tmp_path):
    """The app's GPS distance frozen for a minute (the fix lost), then catching up at once."""
    import pandas as pd

    src = _eucworld_with_counters(tmp_path)
    df = pd.read_csv(src, dtype=str, keep_default_na=False)
    t = (pd.to_datetime(df["datetime"].str[:23]) - pd.Timestamp("2024-06-01 10:00:00")).dt.total_seconds()
    lost = (t >= 200.0) & (t < 260.0)
    df.loc[lost, "gps_distance"] = df.loc[lost.idxmax() - 1, "gps_distance"]
    df.to_csv(src, index=False)
    s = _summary(src)
    assert s.distance_follows == "the app's GPS distance"
    assert s.distance_m == pytest.approx(0.95 * RIDE_M, abs=2.0)
