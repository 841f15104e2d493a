"""``euc-sim ride``: the command on synthetic logs the tests write (known physics,
see :mod:`ridesynth`), its bad-input behaviour, the simulation helpers of
:mod:`euc_sim.rides.sim.simulate`, and the issue's done-criterion on the two real rides
(skipped when ../shared is absent)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from euc_sim.cli import main
from euc_sim.io import is_temporary
from euc_sim.rides.grids.signals import RideAssumptions
from euc_sim.rides.grids.signals import split_at_gaps
from euc_sim.rides.sim.simulate import battery_power, effects_to_inject, ride_params
from euc_sim.rides.sim.envelope import limit_acceleration
from euc_sim.rides.sim.tracking import simulate_profile, to_grid
from euc_sim.rides.source.logs import read_log
from ridesynth import OLD_HEADER, synth_log

SHARED = Path(__file__).resolve().parents[3] / "shared" / "data" / "wheellog"
RIDE_A = SHARED / "2020_05_16_08_02_06.csv"
RIDE_B = SHARED / "2020_05_28_07_52_00.csv"
DURATION = 60.0       # s: long enough for the fit, short enough for four 1 kHz simulations


def run(argv, capsys):
    """Run the CLI; (exit code, stdout, stderr lines); argparse's refusals exit through SystemExit."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, [ln for ln in out.err.splitlines() if ln.strip()]


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    return (synth_log(d / "fit.csv", seed=11, duration=DURATION, gap_at=DURATION / 2),
            synth_log(d / "test.csv", seed=12, duration=DURATION, gap_at=DURATION / 2))


@pytest.fixture(scope="module")
def full_run(logs, tmp_path_factory):
    """One complete run: --compare, --report, --json, simulation included."""
    d = tmp_path_factory.mktemp("out")
    code = main(["ride", str(logs[0]), "--compare", str(logs[1]), "--report", str(d / "rep"),
                 "--json", str(d / "out.json"), "--n-boot", "40", "--seed", "3", "--simulate"])
    assert code == 0
    return json.loads((d / "out.json").read_text()), d / "rep"


# --- the command on synthetic logs -------------------------------------------------------
def test_json_has_contract_form(full_run):
    rep, _ = full_run
    for key in ("effects", "heldout_error_nominal", "heldout_error_augmented", "error_unit",
                "windows"):
        assert key in rep
    assert rep["error_unit"] == "W"
    for e in rep["effects"]:
        assert {"name", "estimate", "unit", "ci95", "rmse_after", "aliases", "evidence"} <= set(e)
        assert e["ci95"][0] <= e["estimate"] <= e["ci95"][1]
    for a, b in rep["windows"]:
        assert 0.0 <= a < b <= DURATION


def test_names_what_the_synthetic_ride_hides(full_run):
    """The logs were made with C_rr = 0.015, k = 0.35 kg/m and P₀ = 20 W."""
    rep, _ = full_run
    names = {e["name"] for e in rep["effects"]}
    assert {"rolling_resistance", "aerodynamic_drag"} <= names
    assert rep["heldout_error_augmented"] < rep["heldout_error_nominal"]
    assert "road_slope" in rep["aliases"]["rolling_resistance"]       # the speed keeps one sign


def test_simulation_against_the_log(full_run):
    """The simulated rider follows the profile; the augmented physics predicts the power better."""
    rep, d = full_run
    sim = rep["simulation"]
    assert sim["ride"] == "test.csv"
    e = sim["errors"]
    assert e["nominal"]["v_mps"] < 0.3 and e["augmented"]["v_mps"] < 0.3
    assert e["augmented"]["P_W"] < e["nominal"]["P_W"]
    assert set(sim["effects_injected"]) == {"rolling_resistance", "aerodynamic_drag"}
    assert sim["falls"] == []
    accepted = {p["name"] for p in rep["parameters"] if p["accepted"]}
    for st in sim["steps"]:                  # each step names what it simulates, all accepted
        assert set(st["physics"]) <= accepted, st["step"]
    last = [st for st in sim["steps"] if st["ran"]][-1]
    assert {"rolling_resistance", "aerodynamic_drag"} <= set(last["physics"])
    table = np.genfromtxt(d / "ride_simulation.csv", delimiter=",", names=True)
    for col in ("t", "v_log", "v_nominal", "v_drivetrain", "M_log", "M_nominal", "M_drivetrain",
                "P_log", "P_nominal", "P_drivetrain", "scored"):
        assert col in table.dtype.names


def test_report_folder(full_run):
    rep, d = full_run
    page = (d / "index.md").read_text()
    assert rep["report"] == "index.html" and rep["report_markdown"] == "index.md" and rep["report_dir"] == "rep"      # relative, no machine path
    linked = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", page)
    assert set(linked) == {"ride_simulation.png"}          # the fits' figures: drawn on index.html
    html = (d / "index.html").read_text()
    assert all(f'Plotly.newPlot("{k}"' in html for k in ("cross_ride", "residuals"))
    for name in linked:
        assert (d / name).stat().st_size > 20_000
    for word in ("aerodynamic_drag", "kg/m", "cannot tell apart", "Windows where", "plausible"):
        assert word in page
    assert not [p for p in d.iterdir() if is_temporary(p)]                     # no temporary files left


def test_halves_and_torque_domain_without_simulation(logs, tmp_path, capsys):
    code, out, err = run(["ride", logs[0], "--json", tmp_path / "o.json", "--domain", "torque",
                          "--no-simulate", "--n-boot", "20"], capsys)
    assert code == 0, err
    rep = json.loads((tmp_path / "o.json").read_text())
    assert rep["error_unit"] == "N·m" and rep["compare"] is None
    assert "second half" in rep["error_measure"] and rep["simulation"] is None
    assert "held-out error" in out


def test_mass_and_radius_reach_the_assumptions(logs, tmp_path, capsys):
    code, _, err = run(["ride", logs[0], "--json", tmp_path / "o.json", "--mass", "100",
                        "--radius", "0.25", "--efficiency", "0.9", "--no-simulate",
                        "--n-boot", "10"], capsys)
    assert code == 0, err
    a = json.loads((tmp_path / "o.json").read_text())["assumptions"]
    assert a["total_mass"] == pytest.approx(100.0) and a["R"] == 0.25
    assert a["m_eq"] == pytest.approx(100.0 + 0.12 / 0.25 ** 2)
    assert a["efficiency_for_torque"] == 0.9


# --- bad input: one line, exit 2, nothing written -----------------------------------------
def _bad(argv, capsys, tmp_path, outputs=("o.json", "rep")):
    code, _, err = run(argv, capsys)
    assert code == 2
    assert len(err) == 1 and err[0].startswith("euc-sim ride: error:"), err
    for name in outputs:
        assert not (tmp_path / name).exists()
    return err[0]


def test_missing_log(tmp_path, capsys):
    msg = _bad(["ride", tmp_path / "nope.csv", "--json", tmp_path / "o.json",
                "--report", tmp_path / "rep"], capsys, tmp_path)
    assert "nope.csv" in msg


def test_missing_compare_log(logs, tmp_path, capsys):
    msg = _bad(["ride", logs[0], "--compare", tmp_path / "other.csv", "--json",
                tmp_path / "o.json"], capsys, tmp_path)
    assert "other.csv" in msg


def test_malformed_log_names_the_column(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text(OLD_HEADER + "\n" + "2024-06-01,10:00:00.000,12.5,65.0,1.0,65.0,90,0,1000,30,0,"
                   "0.00,0.00,0,\n" + "2024-06-01,10:00:00.200,fast,65.0,1.0,65.0,90,0,1000,30,0,"
                   "0.00,0.00,0,\n")
    msg = _bad(["ride", bad, "--json", tmp_path / "o.json", "--report", tmp_path / "rep"],
               capsys, tmp_path)
    assert "bad.csv" in msg and "speed" in msg


def test_log_without_power(tmp_path, capsys):
    log = tmp_path / "nopower.csv"
    rows = [f"2024-06-01,10:00:{i // 5:02d}.{200 * (i % 5):03d},{10 + i % 7}.0" for i in range(100)]
    log.write_text("date,time,speed\n" + "\n".join(rows) + "\n")
    msg = _bad(["ride", log, "--json", tmp_path / "o.json"], capsys, tmp_path)
    assert "power" in msg


def test_unwritable_json(logs, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    msg = _bad(["ride", logs[0], "--json", blocker / "o.json", "--report", tmp_path / "rep"],
               capsys, tmp_path)
    assert "o.json" in msg
    assert blocker.read_text() == "not a folder"


def test_report_is_a_file(logs, tmp_path, capsys):
    (tmp_path / "rep").write_text("x")
    _bad(["ride", logs[0], "--report", tmp_path / "rep", "--json", tmp_path / "o.json"],
         capsys, tmp_path, outputs=("o.json",))
    assert (tmp_path / "rep").read_text() == "x"


@pytest.mark.parametrize("opt", [["--mass", "10"], ["--mass", "-80"], ["--radius", "0"],
                                 ["--efficiency", "1.5"], ["--domain", "speed"],
                                 ["--n-boot", "0"], ["--calibrate-rider", "--no-simulate"]])
def test_bad_options(logs, tmp_path, capsys, opt):
    _bad(["ride", logs[0], "--json", tmp_path / "o.json", *opt], capsys, tmp_path)


# --- the simulation helpers ---------------------------------------------------------------
def test_limit_acceleration_bounds_slope_without_shift():
    t = np.arange(0.0, 20.0, 0.1)
    v = np.where(t > 5.05, 6.0, 0.0)                   # a step at t = 5.05 s
    out = limit_acceleration(t, v, 1.5)
    assert np.max(np.abs(np.diff(out) / np.diff(t))) <= 1.5 + 1e-9
    # mean of a lagging and a leading limiter: the step's midpoint stays where it was
    assert np.interp(3.0, out, t) == pytest.approx(5.05, abs=0.06)
    assert out[t > 5.05 + 6.0 / 1.5] == pytest.approx(6.0)
    assert out[t < 5.05 - 6.0 / 1.5] == pytest.approx(0.0)
    assert v[t > 5.05].min() == 6.0                    # input untouched
    with pytest.raises(ValueError):
        limit_acceleration(t, v, 0.0)


def test_a_fall_ends_the_run_once_and_is_reported(capsys):
    """Issue 19, item 6: the profile is not ridden again after a fall; time and cause said once;
    the progress bar counts the ride's seconds."""
    t = np.arange(0.0, 6.0, 0.1)
    v = np.clip((t - 1.0) / 0.2, 0.0, 1.0) * 6.0          # 0 -> 6 m/s in 0.2 s: 30 m/s²
    said = []
    run = simulate_profile(t, v, ride_params(RideAssumptions()), {}, track_iterations=1,
                           progress=said.append, label="nominal", lean_share=None)
    (fall,) = run.falls
    assert 0.0 < fall["t"] < t[-1] and "exceeds the bound" in fall["cause"]
    assert run.frame is not None and run.frame["t"].iloc[-1] < fall["t"] <= run.frame["t"].iloc[-1] + 0.002
    assert len([n for n in run.notes if "fell" in n]) == 1 and "not ridden again" in run.notes[0]
    assert [m for m in said if m.startswith("riding")] == ["riding 6 s of the logged profile"]
    assert not any("correction" in m for m in said)        # no second run after the fall
    err = capsys.readouterr().err
    assert "nominal ride" in err and "s of ride" in err


def test_a_run_that_stays_up_shows_its_ride_seconds(capsys):
    t = np.arange(0.0, 3.0, 0.1)
    run = simulate_profile(t, np.full(t.size, 3.0), ride_params(RideAssumptions()), {},
                           track_iterations=0, progress=lambda m: None, label="augmented")
    assert run.falls == () and len(run.frame) == 2901
    err = capsys.readouterr().err
    assert "augmented ride: 100%" in err and "3/3 s of ride" in err


def test_windows_are_cut_at_gaps():
    t = np.concatenate([np.arange(0.0, 10.0, 0.1), np.arange(13.0, 20.0, 0.1)])
    assert split_at_gaps([[8.0, 15.0], [1.0, 2.0]], t, min_len=0.5) == [
        [8.0, pytest.approx(9.9)], [13.0, 15.0], [1.0, 2.0]]
    assert split_at_gaps([[9.8, 13.2]], t, min_len=0.5) == []


def test_battery_power_regimes():
    """Losses added in both regimes (the energy balance), no efficiency."""
    P = battery_power([10.0, -10.0], [2.0, 2.0], [0.0, 0.0], 0.2, copper=0.01, idle=5.0)
    assert P == pytest.approx([5.0 + 100.0 + 0.01 * 50.0 ** 2, 5.0 - 100.0 + 0.01 * 50.0 ** 2])


def test_to_grid_is_the_interval_mean():
    tf = np.arange(0.0, 1.0, 0.001)
    out = to_grid(tf, tf, np.array([0.2, 0.5]))
    assert out == pytest.approx([0.2, 0.5], abs=1e-3)


def test_effects_to_inject():
    eff, notes = effects_to_inject({"road_slope": 0.05, "aerodynamic_drag": 0.3,
                                    "drivetrain_idle_loss": 20.0},
                                   ["road_slope", "aerodynamic_drag", "drivetrain_idle_loss"])
    assert eff == pytest.approx({"road_slope": np.arcsin(0.05), "aerodynamic_drag": 0.3})
    assert len(notes) == 1 and "electrical" in notes[0]


# --- the real rides ------------------------------------------------------------------------
@pytest.mark.skipif(not SHARED.is_dir(), reason=f"{SHARED} absent (user's clone)")
def test_real_rides_done_criterion(tmp_path, capsys):
    """On the two five-minute real rides the blocked held-out selection names a plausible
    rolling resistance, drag and the current's lag, the verdict names them, and the page's drivetrain and Estimates agree
    (one parameter set: docs/ride_model.md); the figures and windows are written."""
    code, out, err = run(["ride", RIDE_A, "--compare", RIDE_B, "--json", tmp_path / "o.json",
                          "--report", tmp_path / "rep", "--n-boot", "50", "--no-simulate"],
                         capsys)
    assert code == 0, err
    rep = json.loads((tmp_path / "o.json").read_text())
    named = {"rolling_resistance", "aerodynamic_drag", "current_lag"}
    assert {e["name"] for e in rep["effects"]} == named
    assert set(rep["verdict"]["named"]) == named
    assert rep["heldout_error_augmented"] < rep["heldout_error_nominal"]
    by = {p["name"]: p for p in rep["parameters"]}
    assert by["rolling_resistance"]["accepted"] and not by["copper_loss"]["accepted"]
    assert rep["drivetrain"]["C_rr"]["estimate"] == by["rolling_resistance"]["estimate"]
    page = (tmp_path / "rep" / "index.md").read_text()
    assert "| C_rr |" not in page                  # said once, in the Estimates table
    assert rep["aliases"]["rolling_resistance"] == ["road_slope"]
    assert rep["windows"] and all(0.0 <= a < b <= 340.0 for a, b in rep["windows"])
    for name in ("ride_balance.csv", "index.html", "index.md"):
        assert (tmp_path / "rep" / name).stat().st_size > 2_000
    assert "verdict:" in out
    a, b = rep["windows"][0]                # the terminal says the windows as the page does
    from euc_sim.report.ride.ride_time import span_at
    from euc_sim.rides.summary.rider_view import Clock

    assert "  windows, clock time in the phone's local time (time into the ride, min:s): " \
        + span_at(Clock(**rep["clock"]), a, b, "-") in out and f"{a:.1f}-" not in out


def test_a_fall_in_one_run_is_listed_and_both_runs_are_scored_up_to_it(logs, monkeypatch, tmp_path):
    """The ride JSON's simulation.falls (CONTRACT) and a common scored span after a fall."""
    import euc_sim.rides.sim.simulate as simulate_mod
    from euc_sim.api.functions import analyse_request
    from euc_sim.rides.request import RideRequest
    from euc_sim.rides.sim.tracking import ProfileRun

    real = simulate_mod.simulate_profile
    t_fall = 40.0

    def nominal_falls(t, v, params, effects, seed, dt, iterations, window, progress, label, position,
                      motor, rider, *envelope_band_stops, cancel=None, pool=None):
        run = real(t, v, params, effects, seed, dt, 0, window, None, label, position, motor, rider,
                   *envelope_band_stops, cancel=cancel, pool=pool)
        if label != "nominal":
            return run
        frame = run.frame[run.frame["t"] < t_fall]
        cause = "|gamma| = 0.6 rad exceeds the bound"
        return ProfileRun(frame, ({"t": t_fall, "cause": cause},),
                          (f"rider fell at t = {t_fall} s ({cause}): the simulation stops there",))

    monkeypatch.setattr(simulate_mod, "simulate_profile", nominal_falls)
    req = RideRequest(read_log(logs[1], emit_warnings=False), n_boot=20, seed=3, simulate=True)
    rep = analyse_request(req, tmp_path / "rep").to_json()
    sim = rep["simulation"]
    page = (tmp_path / "rep" / "index.md").read_text()
    from euc_sim.report.ride.ride_time import clock_at
    from euc_sim.rides.summary.rider_view import Clock

    at = clock_at(Clock(**rep["clock"]), t_fall)          # clock time of the ride's own zone
    assert f"The simulated rider fell at {at} (40 s into the ride; nominal: " in page          # said once
    assert f"| {at} (40 s into the ride) |" in page       # the steps' table, alike
    assert page.count("exceeds the bound") == 1
    assert (tmp_path / "rep" / "ride_simulation.png").stat().st_size > 20_000
    assert sim["falls"] == [{"t": t_fall, "cause": "|gamma| = 0.6 rad exceeds the bound", "run": "nominal"}]
    assert any(f"scored up to t = {t_fall:.1f} s" in n for n in sim["notes"])
    for run in ("nominal", "augmented", "drivetrain"):
        assert all(np.isfinite(list(sim["errors"][run].values())))
    assert [s["fell"] for s in sim["steps"] if s["ran"]] == [
        {"t": t_fall, "cause": "|gamma| = 0.6 rad exceeds the bound"}, None]
    assert 0 < sim["scored_rows"]
    for st in (s for s in sim["steps"] if s["ran"]):      # the fallen step's bands: up to its fall
        bands = st["heldout_bands"]["P_W"]
        assert len(bands["ratio_dB"]) == 8 and np.isfinite(bands["ratio_dB"]).all()
        assert bands["rms_dB"] == pytest.approx(np.sqrt(np.mean(np.square(bands["ratio_dB"]))))
    assert "bands, dB (P: fast … slow)" in page and page.count("| P ") >= 2


def test_the_falls_are_said_once_with_the_runs_they_ended():
    from euc_sim.report.ride.page import falls_sentence

    cause = "|phi| = 0.700 rad exceeds the bound 0.7 rad"
    both = [{"t": 842.921, "cause": cause, "run": "nominal"}, {"t": 842.921, "cause": cause, "run": "augmented"}]
    text = falls_sentence(both, 0)
    assert text.count("14 min 03 s into the ride") == 1 and text.count(cause) == 1
    assert "nominal and augmented" in text
    assert "not ridden again" in text and "no error to report" in text
    one = falls_sentence(both[:1], 120)
    assert "(nominal: " in one and "over the 120 scored rows ridden before it" in one
    assert falls_sentence([], 10) is None


def test_the_page_says_when_the_last_step_sways_less_or_more_than_the_log():
    from euc_sim.rides.grids.rider_features import BandRatio
    from euc_sim.report.ride.page import SWAY_DB, sway_sentence
    from euc_sim.rides.sim.sim_steps import SimStep
    from euc_sim.rides.sim.simulate import StepScore

    def step(name, fast, bands=True):
        b = {"P_W": BandRatio([1.0, 2.0], [fast, 0.0], abs(fast) / 2 ** 0.5)} if bands else None
        return StepScore(SimStep(name, name), {}, b, None, None)

    quiet = sway_sentence([step("nominal", 0.0), step("drivetrain", -12.0)])
    assert "(drivetrain)" in quiet and "4.0× less" in quiet and "-12 dB" in quiet
    assert "sway is missing" in quiet
    assert "2.5× more" in sway_sentence([step("drivetrain", 8.0)])
    assert sway_sentence([step("drivetrain", -SWAY_DB + 0.5)]) is None
    assert sway_sentence([step("drivetrain", 0.0, bands=False)]) is None
    assert sway_sentence([]) is None


def test_the_replay_runs_only_when_asked_and_the_page_says_how(logs, tmp_path, capsys, monkeypatch):
    """Without --simulate no simulation runs: the JSON's simulation is null with its why, and the
    page, its plain text and the terminal say how to ask for it."""
    import euc_sim.rides.pipeline as pipeline

    monkeypatch.setattr(pipeline, "_simulate", lambda *a, **k: pytest.fail("the replay ran unasked"))
    code, out, err = run(["ride", logs[0], "--json", tmp_path / "o.json", "--report", tmp_path / "rep",
                          "--n-boot", "10", "--quiet"], capsys)
    assert code == 0, err
    rep = json.loads((tmp_path / "o.json").read_text())
    assert rep["simulation"] is None and "--simulate" in rep["simulation_why"]
    for page in ("index.md", "index.html"):
        assert "ride LOG.csv --simulate" in (tmp_path / "rep" / page).read_text(), page
    assert "simulated replay: not run" in out
    code, _, err = run(["ride", logs[0], "--calibrate-rider", "--no-simulate", "--json", tmp_path / "p.json"],
                       capsys)
    assert code == 2 and len(err) == 1 and "--no-simulate" in err[0]


def test_with_compare_the_replay_runs_unless_refused(logs, tmp_path, capsys, monkeypatch):
    """CONTRACT: the compared ride's JSON carries its "simulation"; --no-simulate skips it."""
    import euc_sim.rides.pipeline as pipeline

    asked = []

    def not_run(an, log, compare, n_boot, seed, jobs, progress, simulate, calibrate_rider, *fitted):
        asked.append(simulate)
        return None, "stubbed"

    monkeypatch.setattr(pipeline, "_simulation", not_run)
    for extra in ([], ["--no-simulate"]):
        code, _, err = run(["ride", logs[0], "--compare", logs[1], "--n-boot", "10", "--quiet",
                            "--json", tmp_path / f"c{len(extra)}.json", *extra], capsys)
        assert code == 0, err
    assert asked == [True, False]
