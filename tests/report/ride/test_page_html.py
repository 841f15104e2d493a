"""The ride page's first screen as a rider reads it (euc_sim.report.ride.page_html): what each
tile says beside its number, built from a synthetic log's summary."""

from __future__ import annotations

from dataclasses import replace

import pytest

from euc_sim.report.ride.page_html import key_figures
from tests.rides.summary.test_summary import _with_spin
from tests.rides.summarysynth import synth_summary_log
from tests.rides.typed_ride import battery, mass_fit, rider_of, with_summary


def _tiles(rider, mass=None, unidentified=None) -> dict:
    return {k.label: k for k in key_figures(rider, mass or mass_fit(), unidentified)}


@pytest.fixture(scope="module")
def rider(tmp_path_factory):
    return rider_of(synth_summary_log(tmp_path_factory.mktemp("log") / "a.csv"))


def test_the_top_speed_tile_says_a_free_spin_was_left_out(tmp_path):
    """apex/0's tile read 122 km/h: the wheel spun at a stop. The tile gives the ride's top
    speed and says the spin apart, with its speed and time."""
    top = _tiles(rider_of(_with_spin(synth_summary_log(tmp_path / "a.csv"))))["Top speed"]
    assert top.value == "25 km/h"
    assert "spun free (off the ground) at 120 km/h at 10:10 (10 min 26 s into the ride): left out" in top.note
    plain = _tiles(rider_of(synth_summary_log(tmp_path / "b.csv")))["Top speed"]
    assert "spun" not in plain.note and plain.note.startswith("average 25 km/h")


def test_the_lead_says_when_named_physics_sits_on_its_edge(ride_result):
    """Blitz 1: C_rr, k and P₀ all on their plausible edges; the verdict said 'the rest is not
    explained' while the first screen said only 'shows what the standard model lacks'."""
    from euc_sim.report.ride import page_html
    from euc_sim.rides.balance.parameters import Parameter

    def lead(accepted, edge):
        params = tuple(Parameter(c, 1.0, (0.5, 1.5), "1", True, True, None, "balance", (0.0, 1.0), c in edge)
                       for c in accepted)
        res = replace(ride_result, parameters=params,
                      verdict=replace(ride_result.verdict, battery_power=True, named=tuple(accepted)))
        return " ".join(page_html._lead(res))

    named = ["aerodynamic_drag", "rolling_resistance", "copper_loss"]
    assert ("(aerodynamic drag, rolling resistance on the edge of their plausible range), the ride asks "
            "for more than that: something the model lacks supplies the rest.") in lead(named, named[:2])
    assert ("(current lag on the edge of its plausible range), the ride asks for more than"
            in lead(["current_lag"], ["current_lag"]))
    assert "edge" not in lead(named, [])


def test_the_pwm_peak_is_marked_on_the_map_only_with_gps(tmp_path):
    """S22 Pro 0 and Mten4 0 (WheelLog, no GPS): the tile read 'marked on the map' above
    'No GPS position in this log: no map'."""
    with_gps = _tiles(rider_of(synth_summary_log(tmp_path / "a.csv")))["Max PWM"]
    assert with_gps.note == "least margin 28 % at 10:05 (5 min 00 s into the ride; marked on the map)"
    no_gps = _tiles(rider_of(synth_summary_log(tmp_path / "b.csv", gps=False)))["Max PWM"]
    assert no_gps.note == "least margin 28 % at 10:05 (5 min 00 s into the ride; marked over time)"


def test_a_tile_gives_a_reason_whole_not_cut_mid_word(rider):
    """Mten4 0's mass tile read 'the battery current is never negative: braking cannot be tol'."""
    from euc_sim.report.ride.page_html import short

    why = ("the battery current is never negative: braking cannot be told from driving, so the "
           "acceleration power's sign is lost and the mass is not identified")
    tile = _tiles(rider, mass_fit(why=why))["Total mass"]
    assert tile.value == "not available" and tile.note == "the battery current is never negative"
    long = "word " * 30
    assert short(long) == ("word " * 14).strip() + " …" and len(short(long)) <= 72


def test_consumption_says_drawn_only_when_no_regeneration_is_logged(tmp_path):
    """Mten4 0 (unsigned current): 'Energy drawn ... regeneration not logged' beside
    'Consumption ... drawn minus regenerated'."""
    signed = _tiles(rider_of(synth_summary_log(tmp_path / "a.csv", regen_amps=5.0)))
    assert signed["Consumption"].note == "drawn minus regenerated"
    unsigned = _tiles(rider_of(synth_summary_log(tmp_path / "b.csv")))
    assert unsigned["Energy drawn"].note == "regeneration not logged"
    assert unsigned["Consumption"].note == "drawn (no regeneration logged)"


def test_no_alarm_is_said_once(tmp_path):
    """Every ride without an alarm read 'Alarms 0 / 0 rows of the log flagged'."""
    none = _tiles(rider_of(synth_summary_log(tmp_path / "a.csv")))["Alarms"]
    assert (none.value, none.note) == ("0", "")
    two = _tiles(rider_of(synth_summary_log(tmp_path / "b.csv", alarm_rows=(500, 501, 900))))
    assert (two["Alarms"].value, two["Alarms"].note) == ("2", "3 rows of the log flagged")


def test_the_battery_tile_says_the_verdict_and_why(rider):
    """V9 0 was run with --wheel v9.csv; its battery tile read 'no specification; 212 mΩ at 25 °C'.
    It now gives the verdict with a new pack's range, or why it cannot tell."""
    b = battery(0.186, resistance_ci95=(0.178, 0.192), resistance_25C_ohm=0.212,
                verdict_why="no resistance figure for the cell X")
    tile = _tiles(replace(rider, battery=b))["Battery resistance"]
    assert tile.value == "186 mΩ"
    assert tile.note == "cannot tell (no resistance figure for the cell X); 212 mΩ at 25 °C" and tile.tone == ""
    new = _tiles(replace(rider, battery=replace(b, verdict="as new", expected_ohm=(0.209, 0.33))))
    new = new["Battery resistance"]
    assert new.note == "as new (new: 209–330 mΩ); 212 mΩ at 25 °C" and new.tone == "good"
    worn = _tiles(replace(rider, battery=replace(b, verdict="worn: +35 % resistance", expected_ohm=(0.1, 0.157))))
    assert worn["Battery resistance"].note.startswith("worn: +35 % resistance (new: 100–157 mΩ)")
    assert worn["Battery resistance"].tone == "bad"


def test_the_pwm_panel_shows_the_logged_peak_the_tile_gives(ride_result):
    """V9 0: 'Max PWM 75 %' (one logged row) marked over a PWM line that never passes 68 %:
    the line is the 10 Hz grid's mean. The panel now carries the logged peak as a point."""
    import numpy as np

    from euc_sim.report.ride.page_html import over_time
    from euc_sim.report.ride.series import RideSeries

    t = np.arange(0.0, 600.0, 0.1)
    series = RideSeries(t=t, gap_s=0.15, channels={"speed_kmh": np.full(t.size, 30.0),
                                                   "pwm_pct": np.full(t.size, 60.0)})
    fig = over_time(with_summary(ride_result, pwm_max_pct=75.0, pwm_max_at_s=300.0, pwm_max_place=None), series)
    peak = [tr for tr in fig["data"] if tr["name"] == "max PWM, logged row"]
    assert len(peak) == 1 and list(peak[0]["y"]) == [75.0] and list(peak[0]["x"]) == [5.0]
    assert peak[0]["yaxis"] == fig["data"][1]["yaxis"]        # on the PWM panel, not the speed one
    assert max(max(tr["y"]) for tr in fig["data"] if tr["name"].startswith("PWM")) < 75.0


def test_no_battery_figures_where_the_logs_power_is_not_the_batterys(ride_result):
    """A WheelLog on a Begode: the app computes the current, so V·I is no battery power and
    neither energy, consumption nor resistance is shown as the battery's."""
    from euc_sim.report.ride.page_html import NOT_POWER, key_figure_lines

    res = with_summary(ride_result, energy_drawn_Wh=309.0, energy_regen_Wh=5.0, Wh_per_km=20.4, distance_m=15000.0)
    res = replace(res, rider=replace(res.rider, battery=battery(0.196, "as new")))
    not_power = {"battery_power": "V·I is not battery power: ..."}
    tiles = _tiles(res.rider, res.mass.mass, not_power)
    for label in ("Energy drawn", "Consumption", "Battery resistance"):
        assert tiles[label].value == "not available" and tiles[label].note == NOT_POWER, label
    fit = res.mass.fit
    res = replace(res, mass=replace(res.mass, fit=replace(fit, drivetrain=replace(fit.drivetrain,
                                                                                  unidentified=not_power))))
    assert not any("309" in line or "20.4" in line or "196" in line for line in key_figure_lines(res))
    assert _tiles(res.rider, res.mass.mass)["Energy drawn"].value == "309 Wh"


def test_distance_and_time_tiles_say_which_counter_they_follow(tmp_path):
    """A P6 page read 13.5 km against the wheel's trip counter's 14.85 and the app's GPS 14.20,
    without saying where its figure came from."""
    from tests.rides.summary.test_summary import _eucworld_with_counters

    t = _tiles(rider_of(_eucworld_with_counters(tmp_path, gps_scale=0.9)))
    assert t["Distance"].value == "3.8 km"
    assert t["Distance"].note == "the app's GPS distance; the wheel's own count 4.2 km (+11 %)"
    assert t["Riding time"].note.startswith("of 10 min; the app's trip and riding clocks; logged 10:00:00–10:10:40 (11 min)")
    wl = _tiles(rider_of(synth_summary_log(tmp_path / "b.csv", gps=False)))
    assert wl["Distance"].note == "the wheel's trip counter"
    assert wl["Riding time"].note.startswith("of 10 min; the wheel's first turn to the last row; logged 10:00")
