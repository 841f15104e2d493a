"""``euc-sim rides``: many synthetic logs of one wheel; bad input is one line and exit 2."""

from __future__ import annotations

import json
import re

import pytest

from euc_sim.cli import main
from tests.rides.summarysynth import synth_summary_log


def _ride(folder, name, R, day, volt=80.0):
    folder.mkdir(parents=True, exist_ok=True)
    return synth_summary_log(folder / name, R_int=R, amps=20.0, amps_wave=0.8, ocv_per_Ah=1.0,
                             volt=volt, ride_s=300.0, start=f"2024-06-{day:02d} 10:00:00", seed=day)


def _fails(argv, match, capsys, tmp_path):
    before = set(tmp_path.rglob("*"))
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:           # refused by argparse (a bounded option)
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert re.search(match, err), err
    assert set(tmp_path.rglob("*")) == before
    return err


def test_history_finds_a_changed_battery(tmp_path, capsys):
    logs = tmp_path / "logs"
    for day, R in ((1, 0.150), (5, 0.152), (9, 0.149), (20, 0.210)):
        _ride(logs / str(day), f"{day}.csv", R, day)
    (logs / "1" / "meta.csv").write_text("wheel,brand\nv9,inmotion\n")      # not a log: skipped
    out_json, report = tmp_path / "h.json", tmp_path / "page"
    assert main(["rides", str(logs), "--json", str(out_json), "--report", str(report),
                 "--n-boot", "20", "--quiet"]) == 0
    h = json.loads(out_json.read_text())
    assert [r["start"][:10] for r in h["rides"]] == ["2024-06-01", "2024-06-05", "2024-06-09", "2024-06-20"]
    r = [x["battery"]["resistance_ohm"] for x in h["rides"]]
    assert r == pytest.approx([0.150, 0.152, 0.149, 0.210], rel=0.03)
    ch = h["change"]
    assert ch["verdict"] == "changed" and ch["p_value"] < 0.05
    assert ch["difference"] == pytest.approx(0.06, abs=0.01)
    assert ch["difference_ci95"][0] > 0
    assert h["rides"][0]["summary"]["distance_m"] == pytest.approx(25 / 3.6 * 300, rel=0.01)
    page = (report / "index.html").read_text()
    assert "Battery internal resistance per ride" in page and "mΩ" in page and "Wh/km" in page
    assert "http://" not in page.split("<body>")[1]        # nothing fetched from the page's data


def test_no_change_when_the_battery_is_the_same(tmp_path):
    logs = tmp_path / "logs"
    for day in (1, 5, 9):
        _ride(logs, f"{day}.csv", 0.15, day)
    out_json = tmp_path / "h.json"
    assert main(["rides", *map(str, sorted(logs.glob("*.csv"))), "--json", str(out_json), "--n-boot", "20", "--workers", "2",
                 "--quiet"]) == 0
    ch = json.loads(out_json.read_text())["change"]
    assert ch["verdict"] == "no change shown" and ch["p_value"] >= 0.05
    assert ch["difference_ci95"][0] < 0 < ch["difference_ci95"][1]


def test_logs_of_different_wheels_fail(tmp_path, capsys):
    a = _ride(tmp_path, "a.csv", 0.15, 1, volt=80.0)      # a 20-cell pack
    b = _ride(tmp_path, "b.csv", 0.15, 2, volt=145.0)     # a 36-cell pack
    _fails(["rides", a, b, "--json", tmp_path / "o.json", "--quiet"], r"b\.csv.*one wheel", capsys, tmp_path)


def test_missing_file_and_empty_folder_fail(tmp_path, capsys):
    _fails(["rides", tmp_path / "nope.csv"], r"nope\.csv", capsys, tmp_path)
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "notes.csv").write_text("a,b\n1,2\n")
    _fails(["rides", empty], r"empty: no ride log", capsys, tmp_path)


def test_unreadable_log_named(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("date,time,speed\n2024-06-01,10:00:00.000,abc\n")
    _fails(["rides", bad, "--quiet"], r"bad\.csv", capsys, tmp_path)


def test_bad_workers_and_rider_weight(tmp_path, capsys):
    a = _ride(tmp_path, "a.csv", 0.15, 1)
    _fails(["rides", a, "--workers", "0"], r"--workers", capsys, tmp_path)
    _fails(["ride", a, "--rider-weight", "-3", "--no-simulate"], r"--rider-weight", capsys, tmp_path)


def test_page_draws_every_figure_in_chromium(tmp_path):
    """The page's scripts run in a real browser: each Plotly figure becomes an SVG."""
    import shutil
    import subprocess

    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("no headless Chromium (Debian's chromium) on this machine: the page is not rendered")
    for day in (1, 5, 9):
        _ride(tmp_path / "logs", f"{day}.csv", 0.15, day)
    assert main(["rides", str(tmp_path / "logs"), "--report", str(tmp_path / "page"), "--n-boot", "10",
                 "--quiet"]) == 0
    dom = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000",
                          "--dump-dom", (tmp_path / "page" / "index.html").as_uri()],
                         capture_output=True, text=True, timeout=120).stdout
    figures = dom.count('class="fig')          # "fig", "fig js-plotly-plot" once drawn
    assert figures == 3
    assert dom.count('class="fig js-plotly-plot') == figures      # every one drawn: no script stopped early
    assert dom.count('class="main-svg"') >= 2 * figures
