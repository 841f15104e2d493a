"""``ride LOG --compare OTHER``: both rides' numbers side by side (the page's tiles, index.md,
the terminal, the JSON's ``compared``), each with its own declared rider weight."""

from __future__ import annotations

import json
import re
import sys
import warnings
from pathlib import Path

import pytest
from drivesynth import drive_log

from euc_sim.cli.app import main

sys.path.append(str(Path(__file__).resolve().parents[2]))
import browser  # noqa: E402


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    d = tmp_path_factory.mktemp("cmp")
    a = drive_log(d / "a.csv", seed=3, duration=300.0)
    b = drive_log(d / "b.csv", seed=5, duration=240.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(["ride", str(a), "--compare", str(b), "--no-simulate", "--n-boot", "10", "--rider-weight",
                     "70", "--rider-weight", "95", "--report", str(d / "rep"), "--json", str(d / "o.json"),
                     "--quiet"])
    return code, d


def test_both_rides_numbers_side_by_side_each_with_its_rider(compared, capsys):
    """Only the first ride's tiles appeared, and one --rider-weight could be given."""
    code, d = compared
    assert code == 0
    rep = json.loads((d / "o.json").read_text())
    c = rep["compared"]
    assert Path(c["recording"]).name == "b.csv"
    assert {"summary", "mass_check", "battery", "total_mass", "clock"} <= set(c)
    assert rep["mass_check"]["declared_rider_kg"] == 70.0 and c["mass_check"]["declared_rider_kg"] == 95.0
    assert c["summary"]["duration_s"] < rep["summary"]["duration_s"]          # its own log, not LOG's
    html = (d / "rep" / "index.html").read_text()
    assert "This ride: a.csv" in html and "Compared ride: b.csv" in html
    assert html.count('<div class="l">Distance</div>') == 2
    md = (d / "rep" / "index.md").read_text()
    key = md.split("## Key figures")[1].split("\n## ")[0]
    assert key.count("- Distance:") == 2 and "- Compared ride, b.csv:" in key
    # the compared ride's tiles nest under its name, not a second flat run of the same labels
    ours, theirs = key.split("- Compared ride, b.csv:")
    assert re.search(r"^- Distance:", ours, re.M) and not re.search(r"^- ", theirs, re.M)
    assert re.search(r"^  - Distance:", theirs, re.M)


def test_the_terminal_gives_both_rides(tmp_path, capsys):
    a = drive_log(tmp_path / "a.csv", seed=3, duration=200.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["ride", str(a), "--compare", str(a), "--no-simulate", "--n-boot", "10", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "Compared ride, a.csv:" in out
    assert len(re.findall(r"^Distance: ", out, re.M)) == 2


def test_the_two_tile_grids_sit_side_by_side_on_the_first_screen(compared, tmp_path):
    browser.chromium_or_skip()
    _, d = compared
    grids = ("JSON.stringify([...document.querySelectorAll('.cols .kf')].map(e => "
             "[Math.round(e.getBoundingClientRect().left), Math.round(e.getBoundingClientRect().top), "
             "Math.round(e.getBoundingClientRect().bottom)]))")
    r = browser.render(d / "rep" / "index.html", tmp_path / "shot.png", (grids,), settle_s=0.5, offline=True)
    boxes = json.loads(r.values[grids])
    assert len(boxes) == 2
    (l1, t1, b1), (l2, t2, b2) = boxes
    assert l2 > l1 + 400 and abs(t1 - t2) < 5 and max(b1, b2) <= 900


@pytest.mark.parametrize("argv, match", [
    (["--rider-weight", "70", "--rider-weight", "80", "--rider-weight", "90"], "at most twice"),
    (["--rider-weight", "70", "--rider-weight", "80"], "needs --compare"),
])
def test_rider_weight_given_too_often_is_refused_in_one_line(argv, match, tmp_path, capsys):
    a = drive_log(tmp_path / "a.csv", seed=3, duration=60.0)
    args = ["ride", str(a), "--no-simulate", "--quiet"] + argv
    if match == "at most twice":
        args += ["--compare", str(a)]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and match in err, err
