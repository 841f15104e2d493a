"""Every number on a ``ride LOG --compare OTHER`` page appears once, and the page leads with what differs.

A ``--compare`` page is built on a synthetic pair (a drag concealed in a copy of the
EUC World twin) and on the shared WheelLog pair (skipped without the data); the
labelled values of its ``index.html`` and ``index.md`` (:mod:`pagenumbers`) must show
each quantity once: no quantity with two values, none repeated in two sections, no
efficiency above 100 %.  The differences' block sits right under the tiles, inside the
first screen (1280×900, headless Chromium), and says each named difference in people's
units with its interval and aliases, or, with nothing named, what the pair could see.
"""

from __future__ import annotations

import sys
import warnings
from dataclasses import replace
from pathlib import Path

import pytest

sys.path.append(str(Path(__file__).resolve().parents[1] / "rides"))
sys.path.append(str(Path(__file__).resolve().parent))

import browser  # noqa: E402
import pagenumbers as P  # noqa: E402
from drivesynth import drive_log  # noqa: E402
import conceal as cc  # noqa: E402

from euc_sim.rides.compare.differences import Difference, Differences  # noqa: E402
from euc_sim.report.ride.differences_page import TITLE, difference_lines, recorded_metadata  # noqa: E402
from euc_sim.rides.grids.power import RHO_AIR  # noqa: E402

WHEELLOG = Path(__file__).resolve().parents[3] / "shared" / "data" / "wheellog"
READY = "document.querySelectorAll('.fig').length === document.querySelectorAll('.fig.js-plotly-plot').length"
BOX_BOTTOM = "document.querySelector('.box').getBoundingClientRect().bottom"
LEAD_BOTTOM = "document.querySelector('.lead').getBoundingClientRect().bottom"


def _compare(log, other, out: Path) -> tuple:
    """``ride LOG --compare OTHER --no-simulate --report``: the folder, the ride JSON and the typed result."""
    from euc_sim.rides.pipeline import ride_pipeline
    from euc_sim.report.ride.contract import ride_json
    from euc_sim.report.ride.report_files import write_report
    from euc_sim.rides.request import ride_request

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = ride_pipeline(ride_request(log, other, n_boot=20, simulate=False))
        rep = ride_json(res, write_report(res, out / "rep"))
    return out / "rep", rep, res


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """The EUC World twin against a copy with +0.5 m² of drag area hidden in every channel."""
    d = tmp_path_factory.mktemp("pair")
    clean = drive_log(d / "a.csv", seed=3, duration=400.0)
    other = cc.write_raw(cc.conceal_wheel_power(cc.read_raw(clean), "aerodynamic_drag", 0.5, eta=1.0), d / "b.csv")
    return _compare(clean, other, d)


@pytest.fixture(scope="module")
def wheellog(tmp_path_factory):
    if not WHEELLOG.is_dir():
        pytest.skip("shared WheelLog rides not found (../shared/data/wheellog)")
    return _compare(WHEELLOG / "2020_05_16_08_02_06.csv", WHEELLOG / "2020_05_28_07_52_00.csv",
                    tmp_path_factory.mktemp("wl"))


def _problems(rep_dir: Path) -> dict:
    html = (rep_dir / "index.html").read_text()
    md = (rep_dir / "index.md").read_text()
    out = {}
    for kind, secs in (("html", P.html_sections(html)), ("md", P.md_sections(md))):
        qs = P.page_quantities(secs, TITLE)
        assert len(qs) >= 8, f"{kind}: only {len(qs)} quantities read: the reader lost the page"
        out[kind] = P.problems(qs)
    return out


@pytest.mark.parametrize("which", ["synthetic", "wheellog"])
def test_every_number_appears_once(which, request):
    rep_dir = request.getfixturevalue(which)[0]
    assert _problems(rep_dir) == {"html": [], "md": []}


def test_a_poor_log_and_a_high_pwm_are_said_once(synthetic, tmp_path):
    """The tiles' data quality and max PWM are not repeated by the lead or the notes."""
    from typed_ride import summary

    from euc_sim.report.ride.page_html import write_ride_html

    res = synthetic[2]
    s = summary(duration_s=400.0, moving_s=380.0, pwm_max_pct=93.0, pwm_max_at_s=120.0,
                gaps={"count": 12, "total_s": 130.0, "longest_s": 40.0}, sampling_hz=2.9, quality="poor",
                quality_sentence="Data quality poor: 2.9 samples/s, 12 gap(s) (33 % of the log); treat every "
                                 "verdict below as weak")
    res = replace(res, rider=replace(res.rider, summary=s),
                  notes=res.notes + ("irregular sampling: intervals 0.1-40 s; 12 gap(s) longer than 1 s",))
    page = write_ride_html(res, tmp_path, None).read_text()
    qs = P.page_quantities(P.html_sections(page), TITLE)
    assert {"max_pwm", "sampling_rate", "gaps"} <= {q.name for q in qs}
    assert P.problems(qs) == []
    assert "treat every verdict below as weak" in page and "close to a cut-out" in page


def test_the_check_sees_a_repeat_two_values_and_an_efficiency_above_one():
    html = ("<body><div class=\"kf\"><div><div class=\"l\">Total mass</div><div class=\"v\">114 kg</div>"
            "</div></div><p class=\"lead\">x</p><details><summary>Mass</summary><div><p>Total mass "
            "(rider + wheel): 114 kg, 95 % interval 80–150 kg; m_eq = 118 kg.</p><p>Again m_eq = 121 kg."
            "</p><table><thead><tr><th>parameter</th><th>estimate</th><th>unit</th></tr></thead><tbody>"
            "<tr><td>eta_motor</td><td>1.15</td><td>dimensionless</td></tr></tbody></table></div></details>"
            "</body>")
    found = P.problems(P.page_quantities(P.html_sections(html), TITLE))
    assert any(p.startswith("total_mass shown in 2 sections") for p in found)
    assert any(p.startswith("m_eq: 118 kg") for p in found)
    assert any(p.startswith("efficiency above 100 %") for p in found)
    same = P.problems(P.page_quantities(P.md_sections("## A\n\nTotal mass: 113.7 kg, so 114 kg.\n"), TITLE))
    assert same == []                                       # one value at two precisions, one section


def test_the_page_leads_with_the_differences(synthetic):
    rep_dir, rep, res = synthetic
    html = (rep_dir / "index.html").read_text()
    assert html.index('class="kf"') < html.index('class="box"') < html.index('class="lead"')
    md = (rep_dir / "index.md").read_text()
    assert md.index(f"## {TITLE}") < md.index("## Verdict")
    lines = difference_lines(res.differences, res.balance.compare)
    assert lines and lines[0] in md and lines[0].startswith("**")
    named = [d for d in rep["differences"] if d["named"]]
    assert ("needed" in lines[0]) == bool(named) and ("Nothing differs" in lines[0]) == (not named)


def test_the_differences_fit_the_first_screen(synthetic, tmp_path):
    browser.chromium_or_skip()
    page = synthetic[0] / "index.html"
    r = browser.render(page, tmp_path / "shot.png", (READY, BOX_BOTTOM, LEAD_BOTTOM), ready=READY)
    assert r.script_errors() == []
    assert r.values[BOX_BOTTOM] <= r.values[LEAD_BOTTOM] <= 900


def _diff(name, est, ci, unit, named, aliases=()):
    return Difference(name, est, tuple(ci), unit, named, "", tuple(aliases))


def test_a_named_drag_in_peoples_units_with_its_interval_and_aliases():
    k = 0.5 * RHO_AIR
    res = Differences((_diff("aerodynamic_drag", 0.25 * k, [0.15 * k, 0.35 * k], "kg/m", True, ["rolling_resistance"]),
                       _diff("internal_resistance", 0.02, [0.01, 0.03], "ohm", True),
                       _diff("total_mass", 3.0, [-20.0, 26.0], "kg", False),
                       _diff("ocv_start", 1.0, [0.5, 1.5], "V", False)),
                      sentence="this ride needed more than the 16 May ride (a.csv).")
    lines = difference_lines(res, "b.csv")
    assert lines[0] == ("**The compared ride (b.csv) needed 0.25 m² more drag area (a jacket? a headwind?); "
                        "20 mΩ more battery resistance (a colder or older pack?) than this ride (16 May).**")
    assert "- Drag area: 95 % interval +0.15 to +0.35 m²; cannot be told apart from rolling resistance" in lines[2]
    assert "- Battery resistance: 95 % interval +10 to +30 mΩ; told apart" in lines[3]
    assert lines[4] == "- Nothing else named; the smallest differences this pair could have seen: mass ±23 kg."
    assert not any("ocv" in x or " V" in x for x in lines)


def test_nothing_named_says_so_and_what_the_pair_could_see():
    res = Differences((_diff("total_mass", -3.0, [-40.0, 30.0], "kg", False),
                       _diff("speed_scale", 0.01, [-0.03, 0.05], "1", False),
                       _diff("rolling_resistance", 0.001, [-0.01, 0.012], "1", False)))
    assert difference_lines(res, "b.csv") == [
        "**Nothing differs between this ride and the compared ride (b.csv) that this pair of rides can show.** "
        "The smallest differences it could have seen: mass ±35 kg, rolling resistance ±1.1 % of the weight, "
        "tyre size (speed scale) ±4.0 %."]
    assert difference_lines(None, "b.csv") == [] and difference_lines(Differences(()), None) == []


def test_the_metadata_of_both_rides_beside_the_difference(tmp_path):
    for n, (kg, bar) in {"0": (85, 2.5), "1": (92, 2.2)}.items():
        (tmp_path / "v9" / n).mkdir(parents=True)
        (tmp_path / "v9" / n / f"{n}.csv").write_text("datetime,speed\n")
        (tmp_path / "v9" / n / "meta.csv").write_text(
            "wheel,brand,year,app,trip_type,rider_weight,tire_pressure,temperature,wind,rain\n"
            f"v9,inmotion,2025,euc_world,0,{kg},{bar},20,low,False\n")
    res = Differences((_diff("total_mass", 8.0, [2.0, 14.0], "kg", True),))
    log = tmp_path / "v9" / "0" / "0.csv"
    meta = recorded_metadata("1.csv", log)
    assert meta["total_mass"] == "the logs record rider weight 85 → 92 kg"
    assert meta["rolling_resistance"] == "the logs record tyre pressure 2.5 → 2.2 bar"
    assert difference_lines(res, "1.csv", log)[2].endswith("; the logs record rider weight 85 → 92 kg.")
    assert recorded_metadata("1.csv") == {} and recorded_metadata("0.csv", log) == {}


def test_index_md_says_both_logs_metadata_once(tmp_path):
    """euc_core's layout (``trips/BRAND/MODEL/N/N.csv`` beside ``meta.csv``): index.md, like the
    HTML page, says the recorded rider weights beside the mass difference, once."""
    rides = {}
    for n, (kg, bar) in {"0": (85, 2.5), "1": (97, 2.2)}.items():
        d = tmp_path / "trips" / "x" / "w" / n
        d.mkdir(parents=True)
        rides[n] = d / f"{n}.csv"
        (d / "meta.csv").write_text(
            "wheel,brand,year,app,trip_type,rider_weight,tire_pressure,temperature,wind,rain\n"
            f"w,x,2025,euc_world,0,{kg},{bar},20,low,False\n")
    clean = drive_log(rides["0"], seed=3, duration=400.0)
    cc.write_raw(cc.conceal_wheel_power(cc.read_raw(clean), "total_mass", 30.0, eta=1.0), rides["1"])
    rep_dir, rep, _ = _compare(clean, rides["1"], tmp_path / "out")
    assert [d["name"] for d in rep["differences"] if d["named"]] == ["total_mass"]
    md = (rep_dir / "index.md").read_text()
    assert md.count("rider weight 85 → 97 kg") == 1
    assert _problems(rep_dir)["md"] == []


def _signed(x: float) -> str:
    return ("+" if round(x) > 0 else "−" if round(x) < 0 else "") + f"{abs(x):.0f}"


def test_the_mass_difference_is_said_once_as_the_key_figures_difference(synthetic):
    """Blitz 4 against 2: the box said "cannot resolve differences smaller than mass ±31 kg" (the
    paired test's size) while the mass section said "+22 kg, 95 % interval −21 to +51 kg" (the two
    rides' own fits, the tiles' difference): one difference stated twice, not alike.  The box
    says the tiles' difference with the paired test's verdict beside it; the mass section
    points there; index.md and the HTML page say the same."""
    rep_dir, rep, _ = synthetic
    d = rep["mass_difference"]
    said = (f"each ride's own fit (the key figures) differs by {_signed(d['estimate'])} kg "
            f"(95 % interval {_signed(d['ci95'][0])} to {_signed(d['ci95'][1])} kg)")
    number = f"{d['estimate']:+.0f} kg"
    for kind, secs in (("md", P.md_sections((rep_dir / "index.md").read_text())),
                       ("html", P.html_sections((rep_dir / "index.html").read_text()))):
        box = "\n".join(t for title, t in secs if title == TITLE)
        assert said in box, kind
        assert "paired test" in box.split(said, 1)[1].split("\n", 1)[0], kind
        assert "mass ±" not in box, kind                 # the paired test's size: not a second figure
        rest = "\n".join(t for title, t in secs if title != TITLE)
        assert "The compared ride minus this one: in 'What differs in the compared ride' above." in rest, kind
        assert number not in rest and said not in rest, kind


def test_one_check_of_the_pwm_model_on_every_part_of_the_page(synthetic):
    """Blitz 4 against 2: the cut-out section said the PWM model predicts "the ride's second
    half, fitted on its first, to 2.1 points RMS" while the folded part and the terminal said
    1.5 points on the compared ride; index.md had no word of the wheel's limit or the cut-out.
    With --compare the page states the compared ride's check (the JSON's ``pwm``), once, and
    index.md carries the limits' section as the page does."""
    import re

    rep_dir, rep, _ = synthetic
    said = f"predicts the logged PWM of the compared ride (b.csv), fitted on this one, to " \
           f"{rep['pwm']['heldout_rmse']:.1f} points RMS"
    for kind, text in (("md", (rep_dir / "index.md").read_text()),
                       ("html", P._text((rep_dir / "index.html").read_text()))):
        assert text.count(said) == 1, kind
        assert "second half, fitted on its first" not in text, kind
        assert not re.search(r"PWM of the other ride predicted from this one: \**\d", text), kind
    md = (rep_dir / "index.md").read_text()
    assert "## Your wheel's limit and the cut-out" in md and "Your wheel's limit: " in md
