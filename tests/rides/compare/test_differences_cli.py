"""``ride LOG --compare OTHER``: the differences list, a hidden drag found, a null naming nothing."""

from __future__ import annotations

import json

import pytest
from drivesynth import drive_log
import conceal as cc

from euc_sim.cli.app import main
from euc_sim.rides.grids.power import RHO_AIR


def _compare(a, b, out):
    assert main(["ride", str(a), "--compare", str(b), "--no-simulate", "--n-boot", "20",
                 "--json", str(out), "--quiet"]) == 0
    return json.loads(out.read_text())


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    return drive_log(tmp_path_factory.mktemp("d") / "a.csv", seed=3, duration=400.0)


def test_a_ride_against_itself_names_nothing(clean, tmp_path):
    rep = _compare(clean, clean, tmp_path / "o.json")
    diffs = rep["differences"]
    for d in diffs:
        assert {"name", "estimate", "ci95", "unit", "named", "why", "aliases"} <= set(d)
        assert "named_given_log_model" not in d
    assert not [d["name"] for d in diffs if d["named"]]
    m = next(d for d in diffs if d["name"] == "total_mass")
    assert m["independent"]["estimate"] == pytest.approx(rep["mass_difference"]["estimate"], abs=1e-9)
    assert m["estimate"] == pytest.approx(0.0, abs=1e-6)
    assert "nothing" in rep["differences_sentence"]
    assert "independently" in rep["differences_interval"] and "jackknife" in rep["differences_interval"]


def test_hidden_drag_is_named_alone_and_sized(clean, tmp_path):
    # η = 1: the balance adds its losses, so a drag hidden behind η < 1 reads k/η when motoring
    other = cc.write_raw(cc.conceal_wheel_power(cc.read_raw(clean), "aerodynamic_drag", 0.5, eta=1.0), tmp_path / "b.csv")
    rep = _compare(clean, other, tmp_path / "o.json")
    by = {d["name"]: d for d in rep["differences"]}
    drag = by["aerodynamic_drag"]
    truth = 0.5 * RHO_AIR * 0.5
    lo, hi = drag["ci95"]
    assert abs(drag["estimate"] - truth) <= 0.3 * truth or lo <= truth <= hi
    assert [n for n, d in by.items() if d["named"]] == ["aerodynamic_drag"]
    assert drag["heldout_gain"] > 0.01
    assert "more drag" in rep["differences_sentence"]
