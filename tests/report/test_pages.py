"""The HTML pages (ride and diagnose) in a real browser, and their figures' specs.

Pages are built once per module from synthetic logs (``tests/rides``'s twins) and
rendered in headless Chromium (:mod:`browser`): no script error, nothing fetched but
map tiles, the first screen inside 1280×900, every figure drawn.  The figure checks
read the Plotly specs in Python.  Without Chromium the browser tests skip, saying so.
"""

from __future__ import annotations

import json
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.append(str(Path(__file__).resolve().parents[1] / "rides"))

import browser  # noqa: E402
from drivesynth import drive_log  # noqa: E402
from ridesynth import synth_log  # noqa: E402

from euc_sim.cli import main  # noqa: E402
from euc_sim.rides.source.logs import read_log

#: True when every Plotly figure on the page has been drawn.
READY = "document.querySelectorAll('.fig').length === document.querySelectorAll('.fig.js-plotly-plot').length"
FIRST_SCREEN = "document.querySelector('.lead').getBoundingClientRect().bottom"
DRAWN = "document.querySelectorAll('.js-plotly-plot .main-svg, .js-plotly-plot canvas').length"


def _moving_gps(path: Path) -> Path:
    """Give the twin's GPS rows a track (a loop of about 1 km), as a real ride has."""
    d = pd.read_csv(path, dtype=str, keep_default_na=False)
    rows = d["gps_lat"] != ""
    s = np.linspace(0, 2 * np.pi, int(rows.sum()))
    d.loc[rows, "gps_lat"] = [f"{x:.6f}" for x in 48.1 + 0.004 * np.sin(s)]
    d.loc[rows, "gps_lon"] = [f"{x:.6f}" for x in -1.7 + 0.006 * np.cos(s) + 0.002 * s]
    d.to_csv(path, index=False)
    return path


def _ride(argv) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main([str(a) for a in argv]) == 0


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    """The EUC World twin (GPS, PWM) through ``ride --no-simulate --report``."""
    d = tmp_path_factory.mktemp("drive")
    log = _moving_gps(drive_log(d / "drive.csv", seed=4, duration=300.0))
    _ride(["ride", log, "--no-simulate", "--n-boot", "10", "--report", d / "rep", "--json", d / "r.json",
           "--quiet"])
    return log, d / "rep", json.loads((d / "r.json").read_text())


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """The WheelLog twin (no GPS, no PWM) with a short simulation."""
    d = tmp_path_factory.mktemp("sim")
    log = synth_log(d / "short.csv", seed=2, duration=60.0, gap_at=None)
    _ride(["ride", log, "--n-boot", "10", "--workers", "1", "--report", d / "rep", "--quiet", "--simulate"])
    return d / "rep"


#: A summary in the CONTRACT's form (SI), to check how the page shows each field.
SUMMARY = {"duration_s": 1500.0, "moving_s": 1260.0, "distance_m": 12345.0, "distance_source": "gps",
           "speed_max_mps": 12.5, "speed_mean_moving_mps": 9.8, "energy_drawn_Wh": 320.0,
           "energy_regen_Wh": 21.0, "Wh_per_km": 24.2, "battery_used_pct": 38.0,
           "range_m_at_this_rate": 32500.0, "pwm_max_pct": 91.0, "pwm_max_at_s": 150.0, "alarms": 3,
           "gaps": {"count": 4, "total_s": 400.0, "longest_s": 250.0}, "sampling_hz": 4.9,
           "quality": "poor", "quality_sentence": "Data quality poor: 4.9 samples/s, 4 gap(s) (27 % of the log)"}
@pytest.fixture(scope="module")
def with_summary(drive, tmp_path_factory):
    """The drive page rebuilt with the summary :data:`SUMMARY`, a declared rider heavier than the
    log's mass and a worn battery."""
    from dataclasses import replace

    from typed_ride import battery, summary

    from euc_sim.rides.grids.signals import ride_signals
    from euc_sim.rides.pipeline import ride_pipeline
    from euc_sim.rides.request import ride_request
    from euc_sim.report.ride.page_html import figure_specs, write_ride_html
    from euc_sim.report.ride.series import RideSeries

    log = drive[0]
    sig = ride_signals(read_log(log, emit_warnings=False))
    series = RideSeries.from_frame(sig.raw, sig.rate)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = ride_pipeline(ride_request(log, n_boot=10, simulate=False))
    r = res.rider
    res = replace(res, rider=replace(
        r, summary=summary(**SUMMARY),
        mass_check=replace(r.mass_check, declared_rider_kg=80.0, verdict="heavier", sentence="heavier"),
        battery=battery(0.152, "worn: +35 % resistance", resistance_ci95=(0.14, 0.16), resistance_25C_ohm=0.147,
                        sentence="worn: +35 % resistance")))
    out = tmp_path_factory.mktemp("summary")
    page = write_ride_html(res, out, series)
    return page, figure_specs(res, series)


@pytest.fixture(scope="module")
def diagnosed(tmp_path_factory):
    d = tmp_path_factory.mktemp("diag")
    _ride(["simulate", "--maneuver", "stop_and_go", "--duration", "10", "--seed", "3",
           "--effect", "aerodynamic_drag=0.3", "--out", d / "hidden.csv"])
    _ride(["diagnose", d / "hidden.csv", "--no-resimulate", "--quiet", "--report", d / "rep"])
    return d / "rep"


def _render(page: Path, tmp_path: Path, *expr):
    browser.chromium_or_skip()
    return browser.render(page, tmp_path / "shot.png", (READY, FIRST_SCREEN, DRAWN) + expr, ready=READY)


@pytest.mark.parametrize("which", ["drive", "simulated", "with_summary", "diagnosed"])
def test_page_renders_offline_without_script_errors(which, request, tmp_path):
    got = request.getfixturevalue(which)
    page = got[0] if which == "with_summary" else (got[1] if which == "drive" else got) / "index.html"
    if which != "with_summary":
        assert (page.parent / "index.md").is_file()        # the plain-text fallback stays
    r = _render(page, tmp_path)
    assert r.script_errors() == []
    assert r.foreign_requests(page) == []                  # nothing but map tiles
    assert r.values[READY] is True and r.values[DRAWN] > 0
    assert r.values[FIRST_SCREEN] <= 900                   # the rider's first screen, unscrolled
    assert r.screenshot.stat().st_size > 20_000


def test_track_drawn_without_tiles(with_summary, tmp_path):
    """The plain track (no tiles, no WebGL) carries every GPS point and the max-PWM mark."""
    drawn = "document.querySelectorAll('#track .scatterlayer .trace .points path.point').length"
    traces = "document.getElementById('track')._fullData.length"
    line = "document.querySelectorAll('#track .scatterlayer .trace path.js-line').length"
    r = _render(with_summary[0], tmp_path, drawn, traces, line)
    assert r.values[drawn] > 100 and r.values[traces] == 3 and r.values[line] > 0


def test_tiles_show_the_summary_in_peoples_units(with_summary):
    text = re.sub(r"<[^>]+>", " ", with_summary[0].read_text().split("<body>")[1].split("<script>")[0])
    for shown in ("12.3 km", "21 min", "45 km/h", "35 km/h while moving", "320 Wh", "21 Wh regenerated",
                  "24.2 Wh/km", "38 %", "range at this rate: 32 km", "91 %", "least margin 9 % at 10:02 (2 min 30 s into the ride",
                  SUMMARY["quality_sentence"].split(": ", 1)[1], "declared rider 80 kg: heavier", "152 mΩ",
                  "worn: +35 % resistance; 147 mΩ at 25 °C"):
        assert shown in text, shown
    raw = with_summary[0].read_text()
    for tone, label in (("bad", "Battery resistance"), ("warn", "Total mass"), ("bad", "Max PWM"),
                        ("bad", "Data quality")):
        assert f'<div class="{tone}"><div class="l">{label}</div>' in raw, label


def test_data_quality_is_the_summarys_verdict_and_its_tone():
    from typed_ride import summary

    from euc_sim.report.ride.page_html import data_quality

    assert data_quality(summary(quality="fair", quality_sentence="Data quality fair: x.")) == \
        ("Data quality fair: x.", "warn")
    assert data_quality(summary(quality="poor", quality_sentence="Data quality poor: y.")) == \
        ("Data quality poor: y.", "bad")


def test_without_summary_the_tiles_say_not_available(drive):
    text = (drive[1] / "index.html").read_text().split("<script>")[0]
    body = (drive[1] / "index.html").read_text()
    assert "Distance" in body and body.count("not available") >= 6
    assert drive[2]["report"] == "index.html" and drive[2]["report_markdown"] == "index.md"
    assert "<title>" in text


_UNIT = re.compile(r", [^,]+$|N·m")


def _spec(fig) -> dict:
    """A figure as its plain spec (the pages' builders write one; Plotly figures convert)."""
    return fig if isinstance(fig, dict) else fig.to_plotly_json()


def _titles(fig) -> list[str]:
    """Every cartesian axis title that has data on it, and the figure's title."""
    lay = _spec(fig)["layout"]
    out = [lay.get("title", {}).get("text", "")]
    for key, ax in lay.items():
        if re.fullmatch(r"[xy]axis\d*", key) and ax.get("type") != "category":
            if key.startswith("x") and ax.get("matches") and not (ax.get("title") or {}).get("text"):
                continue                                    # a shared x axis is titled once, below
            if key.startswith("x") and not (ax.get("title") or {}).get("text") and ax.get("showticklabels") is False:
                continue
            out.append((ax.get("title") or {}).get("text", ""))
    return out


def _unlabelled(figs: dict) -> list:
    bad = []
    for name, fig in figs.items():
        titles = _titles(fig)
        if not titles[0]:
            bad.append((name, "no title"))
        bad += [(name, t) for t in titles[1:] if not _UNIT.search(t or "")]
        for tr in _spec(fig)["data"]:
            marker = tr.get("marker") or {}
            text = ((marker.get("colorbar") or {}).get("title") or {}).get("text") or ""
            if marker.get("showscale", False) and not _UNIT.search(text):
                bad.append((name, "colour bar without unit"))
    return bad


def test_ride_figures_have_titles_and_axes_with_units(with_summary):
    figs = with_summary[1]
    assert set(figs) == {"over_time", "map", "track", "sag", "envelope", "cutout"}
    assert _unlabelled(figs) == []


def test_diagnosis_figures_have_titles_and_axes_with_units(diagnosed):
    from euc_sim.diagnosis.pipeline import diagnose
    from euc_sim.report.diagnosis_html import figure_specs

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnose(diagnosed.parent / "hidden.csv", resimulate=False)
    assert _unlabelled(figure_specs(res)) == []


def test_the_browser_check_sees_errors_and_fetches(tmp_path):
    """The helper itself: a thrown error, a console error and a foreign fetch are all caught."""
    page = tmp_path / "index.html"
    page.write_text("<html><body><div class='lead'>x</div><script>console.error('logged');"
                    "fetch('https://example.com/x').catch(function(){});"
                    "setTimeout(function(){null.x}, 10);</script></body></html>")
    browser.chromium_or_skip()
    r = browser.render(page, tmp_path / "shot.png", (FIRST_SCREEN,), settle_s=1.0)
    errs = r.script_errors()
    assert any("logged" in e for e in errs) and any("TypeError" in e for e in errs)
    assert r.foreign_requests(page) == ["https://example.com/x"]


#: The fits' figures the folded parts draw (Plotly, not PNG files).
FIT_FIGURES = ("cross_ride", "residuals", "pwm")


def test_the_fits_figures_are_drawn_in_the_folded_parts_with_titles_and_units(drive, tmp_path):
    """The held-out balance, its residual and the PWM model: drawn on the page (no PNG beside
    it), each with a title and every y axis titled with its unit; the plain text links none."""
    folder = drive[1]
    assert not {"ride_balance.png", "ride_residuals.png", "ride_pwm.png"} & {p.name for p in folder.iterdir()}
    assert "](cross_ride)" not in (folder / "index.md").read_text()
    ask = {k: (f"document.getElementById('{k}').layout.title.text",
               f"Object.keys(document.getElementById('{k}').layout).filter(a => /^yaxis/.test(a))"
               f".map(a => document.getElementById('{k}').layout[a].title.text)",
               f"document.getElementById('{k}').data.length") for k in FIT_FIGURES}
    r = _render(folder / "index.html", tmp_path, *(e for k in ask.values() for e in k))
    assert r.script_errors() == []
    for name, (title, yaxes, traces) in ask.items():
        assert r.values[title], name
        assert r.values[yaxes] and all(_UNIT.search(t or "") for t in r.values[yaxes]), (name, r.values[yaxes])
        assert r.values[traces] >= 2, name


def test_a_battery_gauge_that_never_moved_says_so(ride_result):
    """A full pack reads 100 % for its first watt-hours: "0 %" alone read as a ride that drew nothing."""
    from dataclasses import replace

    from typed_ride import summary

    from euc_sim.report.ride.page_html import key_figure_lines

    s = summary(energy_drawn_Wh=19.1, battery_used_pct=0.0, battery_start_pct=100.0, battery_end_pct=100.0)
    res = replace(ride_result, rider=replace(ride_result.rider, summary=s))
    assert "Battery used: 0 % (the wheel's gauge read 100 % throughout)" in key_figure_lines(res)
    s = replace(s, battery_used_pct=4.0, battery_end_pct=96.0, range_m_at_this_rate=26000.0)
    res = replace(ride_result, rider=replace(ride_result.rider, summary=s))
    assert "Battery used: 4 % (range at this rate: 26 km)" in key_figure_lines(res)
