"""Nothing a log or spec carries runs on a page.

Hostile text (``javascript:`` links, ``<script>``, ``<img onerror>``, ``"><svg onload>``,
Markdown images, entity-encoded schemes) goes in through every route a page shows
text from: the log's and the compared log's file names, ``meta.csv`` beside a compared
log, a spec's file name, Brand and Model, the folders and names of ``euc-sim rides``'
logs, a diagnosed recording's name.  Each page is opened in headless Chromium
(:mod:`browser`): after load and after clicking every link on it the payload has not
run, every link goes only where :func:`euc_sim.report.html.safe_href` allows, and
the page's own scripts drew every figure with no Content-Security-Policy violation.
Without Chromium the browser tests skip, saying so; the link and policy checks run
everywhere.
"""

from __future__ import annotations

import base64
import hashlib
import json
import re
import sys
import warnings
from pathlib import Path

import pytest

sys.path.append(str(Path(__file__).resolve().parents[1]))
sys.path.append(str(Path(__file__).resolve().parents[1] / "rides"))

import browser  # noqa: E402
from drivesynth import drive_log  # noqa: E402
from summarysynth import synth_summary_log  # noqa: E402

from euc_sim.cli import main  # noqa: E402
from euc_sim.report import html as H  # noqa: E402
from euc_sim.rides.source.logs import read_log

#: What every payload does if it runs: a mark the checks look for.
RUN = "document.body.dataset.pwned=1"
#: Payloads a file name can carry (no "/"), one per way into a page.
NAMED = (f"[a](javascript:{RUN})", f"<img src=x onerror={RUN}>", f'"><svg onload={RUN}>',
         f"![i](JaVaScRiPt:{RUN})", f"[e](java&#115;cript:{RUN})", f"<a href='javascript:{RUN}'>p")
#: Payloads only a field can carry.
FIELDS = (f"[b](//evil.example/{RUN})", f"[c](data:text/html,<script>{RUN}</script>)",
          f"[d]( javascript:{RUN})", f"[f](\tjavascript:{RUN})", f"<script>{RUN}</script>",
          f"[g](vbscript:{RUN})", f"[h](file:///etc/passwd)", "**[i](javascript&colon;x)**")

READY = "document.querySelectorAll('.fig').length === document.querySelectorAll('.fig.js-plotly-plot').length"
DRAWN = "document.querySelectorAll('.js-plotly-plot .main-svg, .js-plotly-plot canvas').length"
RAN_ON_LOAD = "document.body.dataset.pwned !== undefined"
#: Every link's target as written (HTML ``href`` or SVG ``xlink:href``).
HREFS = ("[...document.querySelectorAll('a')].map(a => a.getAttribute('href') ?? "
         "a.getAttributeNS('http://www.w3.org/1999/xlink', 'href')).filter(h => h !== null)")
#: Click every link; a link to a script runs, any other stays on the page (the check goes on).
CLICK = """(async () => {
  document.addEventListener('click', e => {
    const a = e.target.closest('a');
    if (!a) return;
    let scheme = '';   // as the browser parses it: tabs, newlines and leading spaces dropped
    try { scheme = new URL(a.getAttribute('href') ?? a.getAttribute('xlink:href') ?? '', document.baseURI).protocol; }
    catch (err) {}
    if (scheme !== 'javascript:') e.preventDefault();
  }, true);
  const all = [...document.querySelectorAll('a')];
  for (const a of all) a.dispatchEvent(new MouseEvent('click', {bubbles: true, cancelable: true, view: window}));
  await new Promise(r => setTimeout(r, 500));
  return all.length;
})()"""
RAN_ON_CLICK = "document.body.dataset.pwned !== undefined && 'after clicks'"
TEXT = "document.body.textContent"


def _run(argv) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main([str(a) for a in argv]) == 0


# ---- the link allow-list and the policy, without a browser ----------------------------

@pytest.mark.parametrize("url", [
    "https://example.org/a?b=1&c=2#d", "HTTP://example.org", "http://localhost:8000/x", "#top", "#sec-2",
    "residual.png", "concealed/report/index.html", "recordings/", "a-b_c.d.svg"])
def test_links_the_page_may_hold(url):
    assert H.safe_href(url) == url
    assert f'<a href="{H._esc(url)}">x</a>' in H.markdown([f"see [x]({url})"])


@pytest.mark.parametrize("url", [
    "javascript:alert(1)", "JaVaScRiPt:alert(1)", " javascript:alert(1)", "\tjavascript:x", "java\tscript:x",
    "java\nscript:x", "javascript&colon;x", "java&#115;cript:x", "&#106;avascript:x", "%6Aavascript:x",
    "data:text/html,<script>x</script>", "vbscript:x", "file:///etc/passwd", "//evil.example/x", "/etc/passwd",
    "\\\\evil\\x", "../index.md", "a/../../b", "http:/x", "https:evil", "http://evil.example/\u2028x",
    "mailto:a@b", "blob:null/x", "about:blank", "x:y", "\x00javascript:x", "javascript\x01:x", "", " "])
def test_links_the_page_refuses_stay_text(url):
    assert H.safe_href(url) is None
    for line in (f"[click]({url})", f"![img]({url})", f"**[b]({url})**", f"| [t]({url}) |"):
        out = H.markdown([line] if not line.startswith("|") else [line, "| --- |"])
        assert "<a" not in out and "href" not in out, (line, out)
        assert "](" in out or "\n" in url                                    # shown as written


def test_own_links_stay_links_and_attributes_are_quoted():
    out = H.markdown(["The page [`recordings/`](recordings/) and ![a \"q\" <fig>](f.png), "
                      "not [x](javascript:y) **bold**."])
    assert '<a href="recordings/"><code>recordings/</code></a>' in out
    assert '<a href="f.png">figure: a &quot;q&quot; &lt;fig&gt;</a>' in out
    assert "[x](javascript:y)" in out and "<b>bold</b>" in out


def test_a_figure_holds_no_markup_and_a_plain_id():
    frag = H.figure({"data": [{"type": "scatter", "name": f"<!--<script>{RUN}</script>"}]}, "f1")
    script = frag.split("<script>", 1)[1].rsplit("</script>", 1)[0]
    assert "<" not in script and json.loads(re.search(r"var f=(.*);Plotly", script)[1])["data"][0]["name"].startswith("<!--")
    with pytest.raises(ValueError, match="figure id"):
        H.figure({"data": []}, 'x" onmouseover="y')


def _policy(page: str) -> dict[str, list[str]]:
    content = re.search(r'<meta http-equiv="Content-Security-Policy" content="([^"]+)">', page)[1]
    return {d.split()[0]: d.split()[1:] for d in content.split("; ")}


def _sha(text: str) -> str:
    return "'sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode() + "'"


def test_the_policy_runs_only_the_pages_own_scripts():
    fig = H.figure({"data": [{"type": "scatter", "x": [1], "y": [2], "name": "</script><b>"}]}, "f1")
    # a script no builder wrote (as if one forgot to escape) gets no hash, nor one shaped like a figure's
    stray = [f"<script>{RUN}</script>", fig.replace('"data":', f'"data":{RUN},"d":', 1)]
    page = H.page("t <script>", "s", [H.paragraph(f"<script>{RUN}</script>"), fig, *stray])
    p = _policy(page)
    assert p["default-src"] == ["'none'"] and p["base-uri"] == ["'none'"] and p["form-action"] == ["'none'"]
    scripts = re.findall(r"<script>(.*?)</script>", page, re.S)
    assert len(scripts) == 4 and sorted(p["script-src"]) == sorted(map(_sha, scripts[:2]))
    assert not any("unsafe" in v for k, vs in p.items() for v in vs if k != "style-src-attr")
    assert "connect-src" not in p and "worker-src" not in p and p["img-src"] == ["data:", "blob:"]
    # a map's page may fetch the tiles, and only those
    from euc_sim.report.figures import OSM_TILES
    mapped = H.page("m", "", [H.figure({"data": [], "layout": {"map": {"layers": [OSM_TILES]}}}, "m")])
    assert _policy(mapped)["connect-src"] == ["https://tile.openstreetmap.org"]


# ---- every page kind, in a browser -------------------------------------------------

def _spec(folder: Path) -> Path:
    p = folder / f"{NAMED[0]} {NAMED[1]}.csv"
    p.write_text(f"Field|Data\nBrand| {NAMED[2]} {FIELDS[0]}\nModel| {NAMED[3]} {FIELDS[4]}\n"
                 "Wheel diameter| 16 inches\nNet weight| 23.5 kg\nTension| 84 V\n")
    return p


@pytest.fixture(scope="module")
def ride(tmp_path_factory):
    """``ride --compare --wheel --report`` on logs and a spec named with payloads."""
    d = tmp_path_factory.mktemp("ride")
    log = drive_log(d / (" ".join(NAMED[:3]) + ".csv"), seed=4, duration=120.0)
    other = drive_log(d / (" ".join(NAMED[2:]) + ".csv"), seed=5, duration=120.0)
    spec = _spec(d)
    _run(["ride", log, "--compare", other, "--wheel", spec, "--no-simulate", "--n-boot", "10",
          "--report", d / "rep", "--json", d / "r.json", "--quiet"])
    return log, other, d / "rep" / "index.html", spec


@pytest.fixture(scope="module")
def compared(ride, tmp_path_factory):
    """The ride's page with named differences and both logs' ``meta.csv`` fields hostile."""
    from dataclasses import replace

    from euc_sim.rides.compare.differences import Difference
    from euc_sim.rides.grids.signals import ride_signals
    from euc_sim.rides.pipeline import ride_pipeline
    from euc_sim.rides.request import ride_request
    from euc_sim.report.ride.page_html import write_ride_html
    from euc_sim.report.ride.series import RideSeries

    log, other, _, spec = ride
    (log.parent / "meta.csv").write_text(
        "wheel,brand,rider_weight,tire_pressure,temperature,wind\n"
        + ",".join(["w", "b"] + [f'"{x}"' for x in (NAMED[0], NAMED[1], FIELDS[1], NAMED[4] + FIELDS[2])]) + "\n")
    diffs = tuple(Difference(n, e, ci, u, True, "") for n, e, ci, u in (
        ("total_mass", 8.0, (2.0, 14.0), "kg"), ("rolling_resistance", 0.004, (0.001, 0.007), "1"),
        ("speed_scale", 0.02, (0.01, 0.03), "1"), ("internal_resistance", 0.02, (0.01, 0.03), "ohm")))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = ride_pipeline(ride_request(log, other, wheel=spec, n_boot=10, simulate=False))
    res = replace(res, balance=replace(res.balance, compare=str(other)),
                  differences=replace(res.differences, items=diffs))
    sig = ride_signals(read_log(log, emit_warnings=False))
    return write_ride_html(res, tmp_path_factory.mktemp("compared"), RideSeries.from_frame(sig.raw, sig.rate))


@pytest.fixture(scope="module")
def rides(tmp_path_factory):
    """``euc-sim rides --report`` over logs in folders named with payloads."""
    d = tmp_path_factory.mktemp("rides")
    for day, name in ((1, NAMED[0]), (5, NAMED[5]), (9, NAMED[2])):
        (d / "logs" / name).mkdir(parents=True)
        synth_summary_log(d / "logs" / name / f"{NAMED[3 + day % 2]}.csv", R_int=0.15, amps=20.0, amps_wave=0.8,
                          ocv_per_Ah=1.0, ride_s=120.0, start=f"2024-06-{day:02d} 10:00:00", seed=day)
    _run(["rides", d / "logs", "--report", d / "rep", "--n-boot", "10", "--quiet"])
    return d / "rep" / "index.html"


@pytest.fixture(scope="module")
def diagnosed(tmp_path_factory):
    """``diagnose --report`` on a recording named with payloads."""
    d = tmp_path_factory.mktemp("diag")
    rec = d / (" ".join(NAMED[:2] + NAMED[4:]) + ".csv")         # "<a href=...>" for Plotly's titles
    _run(["simulate", "--maneuver", "stop_and_go", "--duration", "10", "--seed", "3", "--out", rec])
    _run(["diagnose", rec, "--no-resimulate", "--quiet", "--report", d / "rep"])
    return d / "rep" / "index.html"


@pytest.mark.parametrize("kind", ["ride", "compared", "rides", "diagnosed"])
def test_nothing_a_log_carries_runs(kind, request, tmp_path):
    page = request.getfixturevalue(kind)
    page = page[2] if kind == "ride" else page
    raw = page.read_text()
    assert "Content-Security-Policy" in raw
    browser.chromium_or_skip()
    r = browser.render(page, tmp_path / "shot.png", (READY, DRAWN, RAN_ON_LOAD, HREFS, TEXT, CLICK, RAN_ON_CLICK),
                       ready=READY, settle_s=1.0)
    assert r.values[RAN_ON_LOAD] is False and r.values[RAN_ON_CLICK] is False
    assert [h for h in r.values[HREFS] if H.safe_href(h) is None] == []
    assert r.values[READY] is True and r.values[DRAWN] > 0                    # its own scripts drew
    assert r.script_errors() == []                                             # nothing refused by its CSP
    assert r.foreign_requests(page) == []
    assert "javascript:" in r.values[TEXT].lower()                            # the payload is shown as text
