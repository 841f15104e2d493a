"""``euc-sim ride LOG --json F --report DIR`` on its defaults (bootstrap, jobs, the closed-loop
simulation along the log) for each log layout it reads: EUC World, WheelLog's old and new
layouts and DarknessBot, the same synthetic minute of riding written by :mod:`layoutsynth`."""

from __future__ import annotations

import csv
import json
import math

import pytest

from euc_sim.cli import main
from euc_sim.rides.source.logs import read_log
from layoutsynth import LAYOUTS, layout_log

#: Layout and variant :func:`euc_sim.rides.source.logs.read_log` must report for each written log.
READ_AS = {"eucworld": ("eucworld", ""), "wheellog_old": ("wheellog", "old"),
           "wheellog_new": ("wheellog", "new"), "darknessbot": ("darknessbot", "")}
#: Layouts that log pitch with a phase current or motor torque: the balance law is read.
WITH_LAW = {"eucworld", "wheellog_new"}


@pytest.fixture(scope="module", params=LAYOUTS)
def ride(request, tmp_path_factory):
    """(layout, log path, exit code, stderr, JSON, report folder) of one default run."""
    import contextlib
    import io

    d = tmp_path_factory.mktemp(request.param)
    log = layout_log(d / f"{request.param}.csv", request.param)
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["ride", str(log), "--json", str(d / "out.json"), "--report", str(d / "rep"), "--simulate"])
    rep = json.loads((d / "out.json").read_text()) if code == 0 else None
    return request.param, log, code, err.getvalue(), rep, d / "rep"


def test_the_log_is_read_in_its_layout(ride):
    layout, log, *_ = ride
    got = read_log(log, emit_warnings=False)
    assert (got.layout, got.variant) == READ_AS[layout]
    assert got.data["v"].max() > 3.0 and got.duration > 55.0


def test_exit_0_and_contract_fields(ride):
    layout, log, code, err, rep, _ = ride
    assert code == 0, err
    assert "Traceback" not in err and "native closed loop unavailable" not in err
    assert rep["recording"] == log.name and rep["error_unit"] == "W"
    for key in ("heldout_error_nominal", "heldout_error_augmented"):
        assert math.isfinite(rep[key]) and rep[key] > 0
    for e in rep["effects"]:
        assert {"name", "estimate", "unit", "ci95", "rmse_after", "aliases", "evidence"} <= set(e)
        assert e["ci95"][0] <= e["estimate"] <= e["ci95"][1]
    mass = rep["total_mass"]
    assert mass["ci95"][0] <= mass["estimate"] <= mass["ci95"][1]
    for name, term in rep["drivetrain"].items():
        assert {"estimate", "ci95", "unit"} <= set(term), name


def test_the_balance_law_is_read_where_the_log_has_it(ride):
    layout, *_, rep, _ = ride
    law = rep["controller"]
    if layout in WITH_LAW:
        assert isinstance(law["law"], str) and law["sign"] in (1, -1)
        assert {t["name"] for t in law["terms"]} >= {"K_p", "K_d"}
        assert 0 < law["heldout"]["r2"] <= 1
    else:
        assert law["law"] is None and law["why"]


def test_the_simulation_ran_along_the_log(ride):
    layout, log, *_, rep, _ = ride
    sim = rep["simulation"]
    assert sim is not None and sim["ride"] == log.name and sim["falls"] == []
    ran = {s["step"] for s in sim["steps"] if s["heldout_rmse"]}
    assert {"nominal", "drivetrain"} <= ran
    assert ("measured_law" in ran) == (layout == "wheellog_new")   # a law in N·m (torque column)
    for step in ("nominal", "augmented"):
        errors = sim["errors"][step]
        assert errors["v_mps"] < 0.3 and math.isfinite(errors["P_W"])


def test_the_report_folder(ride):
    layout, *_, rep, folder = ride
    assert rep["report"] == "index.html" and rep["report_markdown"] == "index.md"
    assert (folder / "index.md").read_text().strip() and (folder / "index.html").stat().st_size > 0
    for name in rep["figures"].values():
        assert (folder / name).stat().st_size > 10_000
    with open(folder / "ride_simulation.csv", newline="") as fh:
        header = next(csv.reader(fh))
    assert {"t", "v_log", "P_log", "v_nominal", "P_nominal", "scored"} <= set(header)
