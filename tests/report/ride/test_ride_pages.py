"""Issue 20: the ride page of every real log never contradicts itself.

All 21 real logs of ``../shared/data`` (18 of nine wheels with their specs, 3
WheelLog rides without one) go through the page/JSON builder once
(``ride_pipeline(ride_request(..., simulate=False))``, 10 bootstrap replicates: the properties
checked do not depend on the replicate count), shared by every test below.
About a minute on one core; skipped when the data are absent (a user's clone).
"""

from __future__ import annotations

import csv
import re
import warnings
from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[4] / "shared" / "data"

pytestmark = pytest.mark.skipif(not (DATA / "euc_core").is_dir(),
                                reason=f"{DATA} absent (user's clone)")


def _logs() -> list[tuple[Path, Path | None]]:
    out = []
    for meta in sorted((DATA / "euc_core").glob("trips/*/*/*/meta.csv")):
        with open(meta, newline="") as fh:
            wheel = next(csv.DictReader(fh))["wheel"]
        out.append((meta.parent / f"{meta.parent.name}.csv",
                    DATA / "euc_core" / "specs" / f"{wheel}.csv"))
    out += [(p, None) for p in sorted((DATA / "wheellog").glob("*.csv"))]
    return out


@pytest.fixture(scope="session")
def pages(tmp_path_factory):
    """(log, spec, report, page text) for each of the 21 logs."""
    from euc_sim.rides.pipeline import ride_pipeline
    from euc_sim.report.ride.contract import ride_json
    from euc_sim.report.ride.page import write_page
    from euc_sim.rides.request import ride_request
    from euc_sim.rides.source.spec import read_spec

    out = []
    root = tmp_path_factory.mktemp("pages")
    for k, (log, spec_path) in enumerate(_logs()):
        spec = read_spec(spec_path) if spec_path else None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = ride_pipeline(ride_request(log, wheel=spec_path, simulate=False, n_boot=10))
        rep, page = ride_json(res), write_page(res, root / str(k), {}).read_text()
        out.append((log, spec, rep, page))
    return out


def _intervals(obj, path=""):
    """Every (path, estimate, ci95) in a JSON object."""
    if isinstance(obj, dict):
        if obj.get("estimate") is not None and obj.get("ci95"):
            yield path, obj["estimate"], obj["ci95"]
        for k, v in obj.items():
            yield from _intervals(v, f"{path}.{k}")
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _intervals(v, f"{path}[{i}]")


def test_all_21_logs_are_read(pages):
    assert len(pages) == 21


def test_every_estimate_lies_inside_its_own_interval(pages):
    bad = []
    for log, _, rep, _ in pages:
        for path, est, (lo, hi) in _intervals(rep):
            tol = 1e-9 * max(1.0, abs(est))
            if not lo - tol <= est <= hi + tol:
                bad.append(f"{log.parent.parent.name}/{log.name}{path}: {est:.4g} [{lo:.4g}, {hi:.4g}]")
    assert not bad, "\n".join(bad)


def test_a_parameter_on_its_bound_prints_as_the_bound(pages):
    for log, _, rep, page in pages:
        assert not re.search(r"\d(\.\d+)?e-(1\d|[2-9]\d)\b", page), f"{log}: a rounding error printed"
        for fit in ("nominal_parameters", "inertia_only_parameters", "all_estimates"):
            for name, entry in rep[fit].items():           # a term on its 0 bound is 0, not 1e-30
                est = entry["estimate"]
                assert est == 0.0 or abs(est) > 1e-9, f"{log}: {fit} {name} = {est!r}, not snapped"


def test_the_spec_reaches_the_balance_fit_and_the_page_says_where_values_came_from(pages):
    for log, spec, rep, page in pages:
        a = rep["assumptions"]
        if spec is not None:
            assert a["R"] == pytest.approx(spec.radius), log
            assert a["sources"]["R"].startswith("spec"), log
            assert "From the wheel's specification" in page, log
        else:
            assert a["sources"]["R"] == "default (Table 3)", log
        if rep["total_mass"]["estimate"] is not None:
            assert a["total_mass"] == pytest.approx(rep["total_mass"]["estimate"]), log
            assert a["sources"]["total_mass"].startswith("found from this log"), log
        else:
            assert a["sources"]["total_mass"] == "default (Table 3)", log
        assert f"({a['sources']['R']})" in page and f"({a['sources']['total_mass']})" in page, log


def test_an_implausible_effect_is_never_the_verdict(pages):
    for log, _, rep, page in pages:
        v = rep["verdict"]
        plausible = {e["name"]: e["plausible"] for e in rep["effects"]}
        assert all(plausible[n] for n in v["named"]), log
        verdict_line = page.split("## Verdict", 1)[1].split("\n- ", 2)[1]
        for name, ok in plausible.items():
            if not ok:
                assert name not in v["named"]
                assert name not in verdict_line.split("candidates")[0], log
        if v["battery_power"] and plausible and not any(plausible.values()):
            assert "not explained by a plausible effect" in v["text"], log


def test_a_log_without_battery_power_gets_no_battery_power_verdict(pages):
    seen = 0
    for log, _, rep, page in pages:
        if "battery_power" in rep["unidentified"]:
            seen += 1
            assert not rep["verdict"]["battery_power"] and not rep["verdict"]["named"], log
            assert "no battery-power verdict" in page.lower() and "ratio **" not in page, log
    assert seen >= 3          # the three MTen4 logs at least


def test_gaps_are_summarised_and_the_notes_agree(pages):
    for log, _, rep, page in pages:
        assert "bridged linearly\n" not in page and not re.search(r"^- .*gap of [\d.]+ s at t", page,
                                                                   re.M), log
        assert len(page.splitlines()) < 200, log
        if any("ride split there, not bridged" in n for n in rep["notes"]):
            assert re.search(r"logging gap\(s\) \(total [\d.]+ s, longest [\d.]+ s", page), log
        assert any(n.startswith("mass and drivetrain fits: gaps up to") for n in rep["notes"]), log


def test_units_are_named_never_1(pages):
    for log, _, _, page in pages:
        assert not re.search(r"\| 1 \|\s*$|\| 1 \| \[", page, re.M), log          # table unit columns
        assert not re.search(r"to -?[\d.]+(e[-+]?\d+)? 1[;:,.]", page), log          # evidence text
        assert "dimensionless" in page, log


def test_the_real_logs_raise_no_false_suspicion_and_carry_the_systematic_parts(pages):
    for log, spec, rep, _ in pages:
        assert rep["input_warnings"] == [], (log, rep["input_warnings"])
        tm = rep["total_mass"]
        if tm["estimate"] is not None:
            assert set(tm["systematic"]) >= {"speed_scale", "current_scale", "efficiency_model", "grade"}
            assert ("rotating_share" in tm["systematic"]) == (spec is not None), log
            lo, hi = tm["statistical_ci95"]
            assert tm["ci95"][0] <= min(lo, tm["estimate"]) and tm["ci95"][1] >= max(hi, tm["estimate"])


def test_one_parameter_set_and_no_efficiency_above_one(pages):
    for log, _, rep, _ in pages:
        params = rep["parameters"]
        names = [p["name"] for p in params]
        assert len(names) == len(set(names)), log
        by = {p["name"]: p for p in params}
        assert all(p["plausible"] for p in params if p["accepted"]), log
        for fit in ("nominal_parameters", "inertia_only_parameters", "all_estimates"):
            assert not [k for k in rep[fit] if k.startswith("eta")], (log, fit)   # no efficiency
        assert {e["name"] for e in rep["effects"]} <= {n for n, p in by.items() if p["accepted"]}, log
        for key, name in (("C_rr", "rolling_resistance"), ("no_load_power", "drivetrain_idle_loss")):
            if key in rep["drivetrain"]:
                assert rep["drivetrain"][key]["estimate"] == by[name]["estimate"], (log, key)

