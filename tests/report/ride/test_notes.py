"""The ride page's notes for people (euc_sim.report.ride.page.summarise_notes): one line for a
ride's hundreds of logging gaps, the JSON keeping every one."""

from __future__ import annotations

from euc_sim.report.ride.page import summarise_notes


def test_gaps_and_short_pieces_become_one_line_each_per_ride():
    notes = (["pwm: taken as 100 - safety_margin"]
             + [f"gap of {1.2 + 0.1 * i:.2f} s at t = {10.0 * i:.2f} s (> max_gap 1 s): ride split "
                f"there, not bridged" for i in range(7)]
             + ["segment 3 has 12 samples, fewer than the 15-sample filter window: left out",
                "segment 5 has 4 samples, fewer than the 15-sample filter window: left out",
                "masses are assumed"]
             + ["b.csv: gap of 3.00 s at t = 5.00 s (> max_gap 1 s): ride split there, not bridged"])
    out = summarise_notes(notes)
    assert out[0] == "pwm: taken as 100 - safety_margin"
    assert out[1].startswith("7 logging gap(s) (total 10.5 s, longest 1.80 s; at t = 0, 10, 20, "
                             "30, 40, … s) longer than 1 s split")
    assert out[2].startswith("2 piece(s) between gaps shorter than the 15-sample filter window "
                             "(16 samples in all)")
    assert out[3] == "masses are assumed"
    assert out[4].startswith("b.csv: 1 logging gap(s) (total 3.0 s, longest 3.00 s; at t = 5 s)")
    assert len(out) == 5


def test_bridged_gaps_of_the_simulated_profile_become_one_line():
    notes = [f"gap of {1.5 + i:.2f} s at t = {i:.2f} s bridged linearly" for i in range(400)]
    out = summarise_notes(notes)
    assert len(out) == 1
    assert out[0].startswith("400 logging gap(s) (total 80400.0 s, longest 400.50 s")
    assert "bridged linearly" in out[0]


def test_other_notes_pass_unchanged():
    notes = ["a", "gap of nothing", "b"]
    assert summarise_notes(notes) == notes


def test_empty_cells_of_many_columns_become_one_line_per_ride():
    """V9 0's notes gave six lines 'gps_lat: 540 of 5990 cells empty (kept as NaN)', one per GPS column."""
    notes = ([f"{c}: 540 of 5990 cells empty (kept as NaN)" for c in ("gps_lat", "gps_lon", "gps_speed")]
             + ["temp: 5 of 5990 cells empty (kept as NaN)", "pwm: taken as 100 - safety_margin",
                "b.csv: roll: 4 of 4819 cells empty (kept as NaN)",
                "b.csv: temp: 4 of 4819 cells empty (kept as NaN)"])
    assert summarise_notes(notes) == [
        "empty cells (of 5990 rows; kept as NaN): gps_lat, gps_lon, gps_speed 540 each; temp 5",
        "pwm: taken as 100 - safety_margin",
        "b.csv: empty cells (of 4819 rows; kept as NaN): roll, temp 4 each"]


def test_the_sampling_note_gives_no_second_rate_beside_the_tiles():
    """Z10 0: the Data quality tile read 12.2 samples/s and the notes "(median 0.077 s, about
    13.0 Hz)": one rate, two values.  The note keeps its median interval; a median rate far
    above the tile's is said as the rate within bursts, as before."""
    from euc_sim.report.ride.page import as_the_tile

    note = ("irregular sampling: intervals 0.007-0.522 s (median 0.077 s, about 13.0 Hz); "
            "0 gap(s) longer than 1 s; 422 interval(s) shorter than 20 ms (near-repeats, kept)")
    said = as_the_tile(note, 12.2)
    assert "Hz" not in said and "(median 0.077 s between rows; the tile's rate counts the whole log)" in said
    bursts = as_the_tile(note.replace("0.077 s, about 13.0 Hz", "0.100 s, about 10.0 Hz"), 3.3)
    assert "10.0 Hz within bursts between gaps" in bursts


def test_the_gaps_are_said_at_their_moments_in_each_rides_clock(ride_result):
    """Blitz 4: "2 logging gap(s) (…; at t = 2248, 3840 s)" while the tiles give clock times:
    the page says each gap's clock time and time into the ride, a compared ride's in its own."""
    from dataclasses import replace

    from euc_sim.report.ride.page import _assumptions_md
    from euc_sim.rides.result import ComparedRide
    from euc_sim.rides.summary.rider_view import Clock

    clock = Clock("2025-07-26T13:51:01.613000+02:00", 7200.0, "UTC+02:00")
    res = ride_result
    other = replace(res.rider, clock=replace(clock, start="2025-07-17T16:48:42.8+02:00"))
    rep = replace(res, rider=replace(res.rider, clock=clock),
                  compared=ComparedRide("2.csv", res.mass.fit, res.mass.mass, other),
                  notes=tuple(f"{who}gap of 3.00 s at t = {t:.2f} s (> max_gap 2.5 s): ride split there, not bridged"
                              for who, t in (("", 2248.0), ("", 3840.0), ("2.csv: ", 60.0))))
    md = "\n".join(_assumptions_md(rep))
    assert "at 14:28 (37 min 28 s into the ride), 14:55 (1 h 04 min into the ride))" in md
    assert "2.csv: 1 logging gap(s) (total 3.0 s, longest 3.00 s; at 16:49 (1 min 00 s into the ride))" in md
    assert "t = 2248" not in md
