"""The ride page where a rider opens it: without network (no empty map frame), and over a log
left running through a long stop (the pause left out of the time axis, marked), in headless
Chromium (:mod:`browser`)."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

sys.path.append(str(Path(__file__).resolve().parents[1] / "rides"))

import browser  # noqa: E402
from drivesynth import drive_log  # noqa: E402

from euc_sim.cli import main  # noqa: E402
from euc_sim.report import html as H  # noqa: E402
from euc_sim.report.ride.page_html import over_time  # noqa: E402
from euc_sim.report.ride.series import RideSeries  # noqa: E402

READY = "document.querySelectorAll('.fig').length === document.querySelectorAll('.fig.js-plotly-plot').length"
#: s the page is left to settle: longer than the page gives a map to draw a tile (html.MAP_WAIT_S).
SETTLE_S = 10.0


@pytest.fixture(scope="module")
def ride_page(tmp_path_factory):
    """The EUC World twin with a GPS track through ``ride --no-simulate --report``."""
    from tests.report.test_pages import _moving_gps

    d = tmp_path_factory.mktemp("offline")
    log = _moving_gps(drive_log(d / "drive.csv", seed=4, duration=300.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main([str(a) for a in ("ride", log, "--no-simulate", "--n-boot", "10", "--report", d / "rep",
                                      "--quiet")]) == 0
    return d / "rep" / "index.html"


def test_offline_the_page_shows_no_empty_map_frame(ride_page, tmp_path):
    """Without network MapLibre draws nothing (its tiles fail, its worker may be refused from
    file://): the map's frame stood empty beside the plain track. It is hidden, and the plain
    track, drawn without tiles, takes the row."""
    browser.chromium_or_skip()
    state = "document.getElementById('map').getAttribute('data-map')"
    shown = "document.getElementById('map').getBoundingClientRect().width"
    track = "document.getElementById('track').getBoundingClientRect().width"
    points = "document.querySelectorAll('#track .scatterlayer .trace .points path.point').length"
    r = browser.render(ride_page, tmp_path / "shot.png", (state, shown, track, points), ready=READY,
                       settle_s=SETTLE_S, offline=True)
    assert r.values[shown] == 0 and r.values[state] == "hidden"
    assert r.values[track] > 1000 and r.values[points] > 100
    assert r.script_errors() == []                 # the guard runs under the page's policy
    assert H.MAP_WAIT_S < SETTLE_S - 1.0


def _paused_series() -> RideSeries:
    """20 min of riding, a 502-minute stop with the log running, 20 min more (2 Hz)."""
    a = np.arange(0.0, 1200.0, 0.5)
    t = np.r_[a, a + 1200.0 + 502 * 60.0]
    v = 20.0 + 5.0 * np.sin(t / 60.0)
    return RideSeries(t=t, gap_s=0.75, channels={"speed_kmh": v, "pwm_pct": 2.0 * v})


def test_a_long_pause_is_left_out_of_the_time_axis(tmp_path, ride_result):
    """MTen4: a 502-minute pause the data-quality tile said was left out squeezed both rides to
    the edges of the time axis. The axis leaves it out, as a marked gap."""
    from dataclasses import replace

    from typed_ride import summary

    from euc_sim.rides.summary.rider_view import Clock

    rider = replace(ride_result.rider, summary=summary(pwm_max_pct=50.0, pwm_max_at_s=1200.0 + 502 * 60.0 + 600.0),
                    clock=Clock("2024-06-08T09:00:00", None, "", ((1199.5, 1200.0 + 502 * 60.0),)))
    fig = over_time(replace(ride_result, rider=rider), _paused_series())
    x = np.concatenate([np.array(tr["x"], float) for tr in fig["data"]])
    assert np.nanmax(x) - np.nanmin(x) < 45.0          # 40 min ridden, the pause a short gap
    assert any("pause of 8 h 22 min left out" in (a.get("text") or "") for a in fig["layout"]["annotations"])
    assert [s["type"] for s in fig["layout"]["shapes"]].count("rect") >= 1
    ticks = list(fig["layout"]["xaxis"]["ticktext"])
    assert ticks[:2] == ["0", "5"] and "530" in ticks        # time into the ride, the pause counted
    browser.chromium_or_skip()
    page = H.write_page(tmp_path / "p", H.page("pause", "", [H.figure(fig, "over_time", 400)]))
    rng = "document.getElementById('over_time')._fullLayout.xaxis.range"
    hover = ("(function(){var gd=document.getElementById('over_time');Plotly.Fx.hover(gd,{xval:30},['xy']);"
             "return document.querySelector('#over_time .hoverlayer').textContent;})()")
    r = browser.render(page, tmp_path / "shot.png", (rng, hover), ready=READY, settle_s=0.5, offline=True)
    assert r.script_errors() == []
    lo, hi = r.values[rng]
    assert hi - lo < 45.0                               # as drawn: each ride keeps about half the width
    # 30 min along the axis: 20 min ridden, the 1.2 min gap, 8.8 min into the second stretch
    assert "at 530.8 min" in r.values[hover]
