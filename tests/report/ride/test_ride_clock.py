"""Times as a rider reads them: clock time in the ride's own zone and time into the ride, on
the tiles (the page, index.md and the terminal say the tiles' strings), and one zone in the
``rides`` table with its PWM peaks flagged as the page judges them."""

from __future__ import annotations

from dataclasses import replace

from euc_sim.cli import main
from euc_sim.report.ride.page_html import key_figure_lines, key_figures
from euc_sim.rides.summary.rider_view import Clock
from tests.rides.summarysynth import as_layout, synth_summary_log
from tests.rides.typed_ride import mass_fit, rider_of


def _tiles(rider) -> dict:
    return {k.label: k for k in key_figures(rider, mass_fit())}


def test_euc_world_stamps_keep_their_zone_and_the_peak_reads_as_clock_and_time_into_the_ride(tmp_path, ride_result):
    """EUC World writes "…T18:15:00.000+0200": the reader made it 16:15 UTC, and the tile said
    "least margin 26 % at 15:25" (time into the ride, read as a clock time)."""
    src = synth_summary_log(tmp_path / "w.csv", start="2024-06-01 18:15:00", pwm_peak=(925.0, 74.0),
                            ride_s=1200.0)
    rider = rider_of(as_layout(src, tmp_path / "e.csv", "eucworld"))
    tiles = _tiles(rider)
    assert "least margin 26 % at 18:30 (15 min 25 s into the ride; marked on the map)" in tiles["Max PWM"].note
    assert "logged 18:15:00–18:35:40 (21 min) in UTC+02:00" in tiles["Riding time"].note
    assert rider.clock.zone == "UTC+02:00" and rider.clock.utc_offset_s == 7200.0
    assert rider.clock.start.startswith("2024-06-01T18:15:00")
    lines = "\n".join(key_figure_lines(replace(ride_result, rider=rider)))   # index.md's and the terminal's first lines
    assert "at 18:30 (15 min 25 s into the ride" in lines


def test_wheellog_clock_is_the_phones_and_said_so(tmp_path):
    rider = rider_of(synth_summary_log(tmp_path / "w.csv", start="2024-06-01 09:00:00", pwm_peak=(65.0, 70.0)))
    assert rider.clock.utc_offset_s is None
    tiles = _tiles(rider)
    assert "at 09:01 (1 min 05 s into the ride" in tiles["Max PWM"].note
    assert "in the phone's local time" in tiles["Riding time"].note


def test_a_long_pause_is_said_with_its_clock_times(tmp_path):
    """A log left running through a stop: the data-quality tile says when the pause was."""
    rider = rider_of(synth_summary_log(tmp_path / "p.csv", start="2024-06-01 09:00:00", gap=(200.0, 1800.0),
                                       ride_s=2400.0))
    assert rider.clock.pauses and rider.clock.pauses[0][1] - rider.clock.pauses[0][0] > 1700
    note = _tiles(rider)["Data quality"].note
    assert "; paused 09:03–09:33 (3 min 20 s into the ride, 30 min)." in note and ".;" not in note


def test_the_rides_table_shows_one_zone_and_flags_a_bad_pwm_peak(tmp_path, capsys):
    """EUC World (UTC+02:00) and WheelLog (the phone's clock) rides started at the same local
    10:00: the table read 08:00 for one and 10:00 for the other; a 94 % peak was not flagged."""
    logs = tmp_path / "logs"
    logs.mkdir()
    src = synth_summary_log(tmp_path / "a.csv", start="2024-06-01 10:00:00", pwm_peak=(100.0, 94.0),
                            amps_wave=0.8, R_int=0.15, ocv_per_Ah=1.0, amps=20.0)
    as_layout(src, logs / "euc_world.csv", "eucworld")
    synth_summary_log(logs / "wheellog.csv", start="2024-06-02 10:00:00", amps_wave=0.8, R_int=0.15,
                      ocv_per_Ah=1.0, amps=20.0)
    assert main(["rides", str(logs), "--n-boot", "10", "--quiet", "--report", str(tmp_path / "page")]) == 0
    out = capsys.readouterr().out
    assert "start times in UTC+02:00" in out
    assert "2024-06-01 10:00  euc_world.csv" in out and "2024-06-02 10:00  wheellog.csv" in out
    assert "max PWM 94 % BAD (≥ 90 %: close to a cut-out)" in out
    page = (tmp_path / "page" / "index.html").read_text()
    assert "start (UTC+02:00" in page and "94 BAD (≥ 90 %" in page and "2024-06-01 10:00" in page


def test_windows_and_falls_read_as_clock_and_time_into_the_ride(ride_result):
    """The residual's windows read "182.1-186.9" (s into the ride) and a fall "at t = 842.9 s"
    while the tiles give clock times of the ride's zone: they now read as the tiles do; a fall
    on the compared ride is said in that ride's clock."""
    from euc_sim.report.ride.page import _localisation_md, falls_sentence
    from euc_sim.report.ride.ride_time import clock_of
    from euc_sim.rides.result import ComparedRide

    clock = Clock("2025-07-26T13:51:01.613000+02:00", 7200.0, "UTC+02:00")
    trace = replace(ride_result.traces[0], localisation={"windows": [[177.8, 183.2], [3897.0, 3905.5]],
                                                         "share": 0.57, "correlations": {}})
    res = replace(ride_result, balance=replace(ride_result.balance, recording="4.csv"), traces=(trace,),
                  rider=replace(ride_result.rider, clock=clock))
    line = next(x for x in _localisation_md(res, {}) if x.startswith("Windows"))
    assert ("(57 % of its energy), clock time in UTC+02:00 (time into the ride, min:s): "
            "13:53:59–13:54:04 (2:58–3:03), 14:55:58–14:56:07 (1:04:57–1:05:06).") in line
    assert "177.8" not in line
    other = replace(clock, start="2025-07-17T16:48:42.819000+02:00")
    compared = replace(res, compared=ComparedRide("2.csv", res.mass.fit, res.mass.mass,
                                                  replace(res.rider, clock=other)))
    fell = falls_sentence([{"t": 842.9, "cause": "|phi| too large", "run": "nominal"}], 10,
                          clock_of(compared, "2.csv"))
    assert "fell at 17:02 (14 min 03 s into the ride; nominal: |phi| too large)" in fell
    assert clock_of(compared, "4.csv") is clock and clock_of(res, "2.csv") is clock
    bare = replace(res, traces=(replace(trace, localisation={"windows": [[177.8, 183.2]], "share": None,
                                                             "correlations": {}}),),
                   rider=replace(res.rider, clock=None))
    assert "time into the ride, min:s: 2:58–3:03." in _localisation_md(bare, {})[3]


def _entry(name: str, start: str, offset):
    from tests.rides.typed_ride import battery, ride_entry_of

    summary = {"duration_s": 1000.0, "moving_s": 900.0, "distance_m": 5000.0, "distance_source": "wheel",
               "speed_max_mps": 10.0, "speed_mean_moving_mps": 6.0, "energy_drawn_Wh": 100.0, "Wh_per_km": 20.0,
               "battery_used_pct": 10.0, "pwm_max_pct": 60.0}
    return ride_entry_of(f"/x/{name}", start, offset, summary, battery(0.15, resistance_ci95=(0.14, 0.16)))


def test_the_rides_are_in_the_order_they_were_ridden_whatever_zone_their_log_keeps():
    """EUC World keeps UTC (a ride at 10:00 in UTC+02:00 is stored as 08:00), WheelLog the
    phone's clock (a ride at 09:00 local is stored as 09:00): sorted on the stored strings the
    later EUC World ride came first.  Sorted on the instant (the phone's clock taken in the
    zone the table shows), the table reads down in time, in one zone."""
    from euc_sim.rides.logbook.history import ride_history
    from euc_sim.report.ride.history_page import history_page, start_in, table_zone

    h = ride_history([_entry("euc_world.csv", "2024-06-01T08:00:00", 7200.0),
                      _entry("wheellog.csv", "2024-06-01T09:00:00", None),
                      _entry("later.csv", "2024-06-01T09:30:00", 7200.0)])
    assert [e.path[3:] for e in h.rides] == ["wheellog.csv", "euc_world.csv", "later.csv"]
    off, zone = table_zone(h)
    assert [start_in(e, off) for e in h.rides] == ["2024-06-01 09:00", "2024-06-01 10:00", "2024-06-01 11:30"]
    page = history_page(h)
    assert page.index("wheellog.csv") < page.index("euc_world.csv") < page.index("later.csv")
    assert f"start ({zone})" in page and zone.startswith("UTC+02:00")


def test_the_riding_time_says_which_clock_gives_each_length(ride_result):
    """Blitz 2: "18 min (of 19 min; the app's trip and riding clocks; 16:48–17:10 in UTC+02:00)":
    the span reads 22 min against the 19 min beside it.  The span is said as the log's, with its
    own length where it differs."""
    r = ride_result.rider
    rider = replace(r, summary=replace(r.summary, moving_s=1091.0, duration_s=1111.0, logged_s=1289.11,
                                       duration_follows="the app's trip and riding clocks"),
                    clock=Clock("2025-07-17T16:48:42.819000+02:00", 7200.0, "UTC+02:00"))
    note = _tiles(rider)["Riding time"].note
    assert note == "of 19 min; the app's trip and riding clocks; logged 16:48:42–17:10:11 (21 min) in UTC+02:00"
    same = replace(rider, summary=replace(rider.summary, logged_s=1120.0))
    assert _tiles(same)["Riding time"].note.endswith("; logged 16:48–17:07 in UTC+02:00")


def test_a_logged_span_never_reads_longer_or_shorter_than_its_length(ride_result):
    """Blitz 2 said "logged 16:48–17:10 (21 min)": a clock's minutes, 22 apart, beside the length rounded,
    21 (21.5 min).  Over random starts and lengths, minutes are said only where they are as many as the
    length; else seconds, within half a minute of it."""
    import re
    from datetime import datetime, timedelta

    import numpy as np

    from euc_sim.report.ride.ride_time import span_words

    rng = np.random.default_rng(5)
    for _ in range(300):
        start, logged = rng.uniform(0, 86400), rng.uniform(60, 7200)
        summary = replace(ride_result.rider.summary, logged_s=logged, duration_s=0.0)
        clock = Clock(f"{datetime(2025, 7, 17) + timedelta(seconds=start):%Y-%m-%dT%H:%M:%S.%f}", 0.0, "UTC")
        words = span_words(clock, summary)
        t0, t1, h, m = re.fullmatch(r"logged (\S+)–(\S+) \((?:(\d+) h )?(\d+) min\) in UTC", words).groups()
        said = 60 * int(h or 0) + int(m)
        secs = [sum(int(x) * f for x, f in zip(t.split(":"), (3600, 60, 1))) for t in (t0, t1)]
        span = (secs[1] - secs[0]) % 86400
        if t0.count(":") == 1:
            assert span // 60 == said, words
        else:
            assert abs(span - 60 * said) <= 31, words


def test_the_residual_figure_draws_the_windows_on_the_minutes_the_page_says():
    """The page says a window "2:58–3:03" (min:s into the ride) beside a figure whose axis read
    178–183 s: the figure's time axis is in minutes, as the ride-over-time figure's."""
    import numpy as np

    from euc_sim.rides.balance.residual import ResidualTrace, moving_mean
    from euc_sim.report.ride.fit_figures import residuals_figure

    t = np.arange(0.0, 600.0, 0.1)
    r = np.sin(t / 10.0)
    loc = {"windows": [[177.8, 183.2]], "share": 0.57, "correlations": {}}
    fig = residuals_figure([ResidualTrace("4.csv", t, r, 0.5 * r, "W", loc, True, moving_mean(t, 0.5 * r))])
    shade = fig["layout"]["shapes"][0]
    assert (shade["x0"], shade["x1"]) == (177.8 / 60.0, 183.2 / 60.0)
    assert fig["layout"]["xaxis"]["title"]["text"] == "time from the start of the log, min"
    assert max(x for x in fig["data"][0]["x"] if x is not None) < 10.0 + 1e-9
