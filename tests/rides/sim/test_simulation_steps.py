"""The simulated ride as ordered modelled steps (``simulation.steps``, :mod:`euc_sim.rides.sim.sim_steps`).

The steps are data built one from the other; the simulated phase current, pitch and
PWM land in the log's convention: a ride under a known law, written as EUC World
writes it (pitch sign −1, −2° mounting offset, phase current M_d/K_t), is reproduced
far better by the step running that law than by the paper's PD.
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from euc_sim.controllers.motor import MotorPD
from euc_sim.model.parameters import TABLE3
from euc_sim.rides.drive.drivetrain import Term
from euc_sim.rides.law.controller_report import ControllerFit
from euc_sim.report.ride.contract import sim_step_json, simulation_json
from euc_sim.rides.sim.sim_steps import (STEP_BUILDERS, LogChannels, StepInputs, build_steps,
                                     drivetrain_step, log_channels, measured_law_step, nominal_step,
                                     simulated_pwm)
from euc_sim.rides.source.logs import read_log

NOM: dict = {}                        # the inertia-only balance fits nothing
AUG = {"copper_loss": 0.004, "drivetrain_idle_loss": 30.0,
       "rolling_resistance": 0.012, "aerodynamic_drag": 0.3}
#: The balance law's terms: name -> (estimate, ci95, unit).
TERMS = {"K_p": (5687.0, None, "N·m/rad"), "K_d": (120.0, None, "N·m·s/rad"),
         "pitch_zero": (-0.03, None, "rad (logged)"), "K_i": (50.0, None, "N·m/(rad·s)")}
DRIVETRAIN = {"back_emf_per_speed": Term(7.5, None, "V·s/m"), "resistive_drop": Term(0.004, None, "V/N"),
              "dead_time": Term(0.03, None, "1"), "back_emf_constant": Term(1.6, None, "V·s/rad")}


def _law(terms=TERMS) -> ControllerFit:
    """A balance law as the fit ride gives it (PD + tilt-back, in N·m, logged pitch sign −1)."""
    law = SimpleNamespace(terms=dict(terms), names=["K_p", "K_d", "pitch_zero", "K_i"], sign=-1, sign_share=1.0,
                          channel="torque", unit="N·m", heldout_r2=0.6, nominal_r2=0.5, blind_r2=0.1,
                          heldout_rmse=10.0, history=[])
    return ControllerFit(law, heldout_r2=0.6, heldout_ride="fit.csv")


LAW = _law()


def inputs(law=LAW, drivetrain=DRIVETRAIN, voltage=151.2) -> StepInputs:
    return StepInputs(TABLE3, NOM, AUG, ("rolling_resistance", "aerodynamic_drag", "copper_loss",
                                         "drivetrain_idle_loss"), law=law, drivetrain=drivetrain, voltage=voltage)


def test_an_unresolved_kd_is_damped_and_said_in_the_step_and_its_json():
    """Lynx 0's K_d came out −37 (interval [−51, −29]); the step damps the pitch mode instead of 0."""
    from euc_sim.controllers.damping import damping_floor

    terms = dict(TERMS, K_d=(-37.0, (-51.1, -29.2), "N·m·s/rad"))
    nom, law, dt = build_steps(inputs(_law(terms)))
    kd = damping_floor(TABLE3, 5687.0)
    assert law.motor.Kd == pytest.approx(kd, rel=1e-6) and dt.motor.Kd == law.motor.Kd
    assert "not resolved" in law.what and "ζ ≥ 0.7" in law.what
    described = sim_step_json(law)
    assert described["motor"]["K_d"] == pytest.approx(kd, rel=1e-6)
    assert any("-37" in n and "not resolved" in n for n in described["notes"])


def test_steps_without_a_law_skip_the_measured_law_and_build_on_the_nominal():
    steps = build_steps(inputs(ControllerFit(None, "no pitch in the log"), {}, None))
    assert [s.name for s in steps] == ["nominal", "measured_law", "drivetrain"]
    nom, law, dt = steps
    assert nom.motor == MotorPD() and nom.rider is None and nom.effects == {} and nom.why is None
    assert law.why is not None and "no pitch in the log" in law.why
    assert dt.why is None and dt.motor == MotorPD()                     # built on the nominal
    assert dt.effects == {"rolling_resistance": 0.012, "aerodynamic_drag": 0.3}
    assert dt.power == {"copper_loss": 0.004, "drivetrain_idle_loss": 30.0}
    assert any("no voltage limit" in n for n in dt.notes)
    assert nom.power == {"drivetrain_idle_loss": 0.0}               # no loss: P = P_mech


def test_measured_law_and_voltage_limit_carry_into_the_last_step():
    nom, law, dt = build_steps(inputs())
    assert (law.motor.Kp, law.motor.Kd) == (5687.0, 120.0) and law.why is None
    assert any("K_i" in n for n in law.notes)                          # measured, not simulated
    assert (dt.motor.Kp, dt.motor.Kd) == (5687.0, 120.0)
    assert dt.motor.voltage == pytest.approx(151.2) and dt.motor.back_emf == pytest.approx(7.5)
    assert dt.motor.drop == pytest.approx(0.004 / TABLE3.R)
    assert dt.motor.dead_time == pytest.approx(0.03)
    d = sim_step_json(dt)
    assert d["step"] == "drivetrain" and d["ran"] and d["motor"]["voltage"] == pytest.approx(151.2)


def test_a_new_step_is_one_builder_and_the_next_step_inherits_it():
    """The extension point a calibrated rider uses: a builder between law and drivetrain."""
    rider = object()

    def calibrated(prev, inp):
        return replace(prev, name="calibrated_rider", what="rider fitted on the log", rider=rider,
                       notes=())

    builders = STEP_BUILDERS[:2] + (calibrated,) + STEP_BUILDERS[2:]
    steps = build_steps(inputs(), builders)
    assert [s.name for s in steps] == ["nominal", "measured_law", "calibrated_rider", "drivetrain"]
    assert steps[2].rider is rider and steps[2].motor.Kp == 5687.0
    assert steps[3].rider is rider                                      # carried to the next step
    assert steps[1].rider is None                                       # earlier steps untouched
    assert STEP_BUILDERS == (nominal_step, measured_law_step, drivetrain_step)


def test_log_channels_from_the_drivetrain_and_the_law():
    ch = log_channels(DRIVETRAIN, LAW, balance_heldout=500.0)
    assert ch.k_t == pytest.approx(1.6) and ch.pitch_sign == -1.0
    assert ch.pitch_zero == pytest.approx(-0.03) and ch.balance_heldout == 500.0
    assert ch.pwm == {"K_v": 7.5, "r_F": 0.004, "dead_time": 0.03}
    none = log_channels(None, ControllerFit(None, "no pitch"))
    assert none.k_t is None and none.pwm is None and none.pitch_sign is None


def test_simulated_pwm_is_the_duty_model():
    v, F, V = np.array([5.0, 10.0, 10.0]), np.array([100.0, -50.0, 0.0]), np.array([100.0, 90.0, 80.0])
    duty = simulated_pwm({"K_v": 7.0, "r_F": 0.01, "dead_time": 0.02}, v, F, V)
    want = (7.0 * v + 0.01 * F + 0.02 * V * np.sign(F)) / V * 100.0
    np.testing.assert_allclose(duty, want, rtol=1e-12)


@pytest.fixture(scope="module")
def law_log(tmp_path_factory):
    """80 s under a known law (K_p 2,000, K_d 200, tilt-back; the 45 N·m limit lifted: the
    replay's speed, smoothed from the log, needs a little more), written as EUC World writes it."""
    from euc_sim.rides.synth import lawsynth

    law = dict(lawsynth.LAW, torque_limit=250.0)
    ride = lawsynth.law_ride(seed=1, duration=80.0, law=law)
    return lawsynth.eucworld_log(ride, tmp_path_factory.mktemp("law") / "law.csv", seed=1), lawsynth, law


def test_the_true_law_reproduces_the_logs_current_and_pitch(law_log):
    from euc_sim.rides.grids.signals import RideAssumptions, ride_signals
    from euc_sim.rides.sim.sim_steps import SimStep
    from euc_sim.rides.sim.simulate import simulate_ride

    path, ls, law = law_log
    sig = ride_signals(read_log(path, emit_warnings=False), RideAssumptions(torque_constant=ls.K_T))
    steps = [SimStep("nominal", "paper PD", MotorPD(), None, {}, NOM),
             SimStep("measured_law", "the true law", MotorPD(**law), None, dict(ls.ROAD), NOM),
             SimStep("skipped", "never run", why="for the test")]
    ch = LogChannels(k_t=ls.K_T, pitch_sign=-1.0, pitch_zero=math.radians(-2.0), balance_heldout=100.0)
    sim = simulate_ride(sig, steps, read_log(path, emit_warnings=False), track_iterations=0, channels=ch)
    e = sim.errors
    assert sim.ran == ["nominal", "measured_law"] and not sim.falls
    for key in ("P_W", "I_phase_A", "pitch_rad", "M_Nm", "v_mps"):
        assert key in e["measured_law"]
    assert "pwm_pct" not in e["measured_law"]                   # no duty model given
    assert e["measured_law"]["pitch_rad"] < 0.5 * e["nominal"]["pitch_rad"]
    assert e["measured_law"]["pitch_rad"] < math.radians(1.0)
    assert e["measured_law"]["I_phase_A"] < e["nominal"]["I_phase_A"]
    js = simulation_json(sim)
    assert js["errors"]["augmented"] == e["measured_law"] and js["errors"]["nominal"] == e["nominal"]
    by = {s["step"]: s for s in js["steps"]}
    assert by["skipped"]["ran"] is False and by["skipped"]["heldout_rmse"] == {}
    assert by["measured_law"]["ratio_to_balance"] == pytest.approx(e["measured_law"]["P_W"] / 100.0)
    assert by["measured_law"]["target_ratio"] == 1.2 and by["nominal"]["fell"] is None
    # level and spectrum, channel by channel: the law sets the slow pitch (the paper's soft PD leans
    # 3x as far); the logged rider's 5 N·m motor noise is in the fast bands, the simulated rider has none
    bands = {k: by[k]["heldout_bands"] for k in ("nominal", "measured_law")}
    assert all(set(b) == {"P_W", "I_phase_A", "pitch_rad"} for b in bands.values())
    assert abs(bands["measured_law"]["pitch_rad"]["ratio_dB"][-1]) < 3.0
    assert bands["nominal"]["pitch_rad"]["ratio_dB"][-1] > 6.0
    assert all(b["P_W"]["ratio_dB"][0] < -6.0 and b["I_phase_A"]["ratio_dB"][0] < -6.0 for b in bands.values())
    assert by["skipped"]["heldout_bands"] is None
    for col in ("I_log", "pitch_log", "I_measured_law", "pitch_nominal"):
        assert col in sim.table


def test_a_figure_per_step_with_the_logs_channels(law_log, tmp_path):
    """Pitch and phase current panels, one line per step, titled and labelled."""
    from figcheck import assert_readable

    from euc_sim.rides.grids.signals import RideAssumptions, ride_signals
    from euc_sim.rides.sim.sim_steps import SimStep
    from euc_sim.io import save_figure
    from euc_sim.report.ride.simulation_figure import ride_simulation_figure
    from euc_sim.rides.sim.simulate import simulate_ride

    path, ls, law = law_log
    sig = ride_signals(read_log(path, emit_warnings=False), RideAssumptions(torque_constant=ls.K_T))
    steps = [SimStep("nominal", "paper PD", MotorPD(), None, {}, NOM),
             SimStep("measured_law", "the true law", MotorPD(**law), None, {}, NOM)]
    sim = simulate_ride(sig, steps, read_log(path, emit_warnings=False), track_iterations=0,
                        channels=LogChannels(k_t=ls.K_T, pitch_sign=-1.0, pitch_zero=-0.035))
    fig = ride_simulation_figure(sim)
    assert_readable(fig)
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert any("phase current" in s for s in labels) and any("pitch" in s for s in labels)
    assert any("PWM" in s for s in labels) is False                 # no simulated duty, no panel
    for ax in fig.axes[1:]:
        names = [ln.get_label() for ln in ax.get_lines()]
        assert any("measured_law" in n for n in names) and any("nominal" in n for n in names)
    assert save_figure(fig, tmp_path / "s.png", dpi=100).stat().st_size > 20_000


def _table_script():
    import ride_simulation_table

    return ride_simulation_table


def test_the_shared_pairs_table(tmp_path):
    """16 ordered pairs; a row gives each step's error and ratio (bold within 1.2×), skipped
    steps, the scored span after a fall, and no stray '|' from a fall's cause."""
    mod = _table_script()
    todo = mod.pairs(tmp_path, list(mod.WHEELS))
    assert len(todo) == 16 and {p["name"] for p in todo} >= {"lynx_0_to_2", "lynx_2_to_0",
                                                             "master_pro_V2_6_to_3"}
    step = lambda name, p, r, ran=True: {"step": name, "ran": ran, "heldout_rmse": {"P_W": p} if ran else {},  # noqa: E731
                                         "ratio_to_balance": r, "target_ratio": 1.2}
    sim = {"steps": [step("nominal", 1200.0, 2.4), step("measured_law", None, None, ran=False),
                     step("drivetrain", 550.0, 1.1)],
           "falls": [{"t": 300.0, "cause": "|phi| = 0.701 rad exceeds the bound 0.7 rad", "run": "nominal"}],
           "notes": ["every step is scored up to t = 300.0 s, where the first fall ended a run "
                     "(2500 of 10000 scored rows)"], "scored_rows": 2500, "pitch_scored_rows": 0}
    res = [{"pair": todo[0], "json": {"heldout_error_augmented": 500.0, "simulation": sim}},
           {"pair": todo[1], "error": "not run (no ride.json yet)"}]
    md = mod.rows(res)
    row = md[2]
    assert "1,200 (2.40)" in row and "skipped" in row and "550 (1.10)" in row   # fell: not bold
    sim_whole = dict(sim, falls=[], notes=[])
    row2 = mod.rows([{"pair": todo[0], "json": {"heldout_error_augmented": 500.0, "simulation": sim_whole}}])[2]
    assert "550 (**1.10**)" in row2 and "1,200 (2.40)" in row2
    assert "250 s (25 %)" in row and "phi = 0.701 rad" in row
    assert all(r.count("|") == md[0].count("|") for r in md[2:])      # one cell per column
    mod.write_doc(tmp_path / "t.md", res, ["--out", "X"])
    assert "ride_simulation_table.py --out X" in (tmp_path / "t.md").read_text()


def test_pitch_without_a_convention_is_moved_to_the_logs_mean_in_a_new_table():
    from euc_sim.rides.sim.simulate import _align_pitch

    n = 50
    table = pd.DataFrame({"v_log": np.full(n, 5.0), "pitch_log": np.full(n, 0.02),
                          "pitch_nominal": np.full(n, -0.1), "pitch_drivetrain": np.linspace(0.0, 0.2, n)})
    before = table.copy()
    moved, note = _align_pitch(table, np.ones(n, bool), ["nominal", "drivetrain"])
    pd.testing.assert_frame_equal(table, before)                       # the input is left alone
    assert moved["pitch_nominal"].to_numpy() == pytest.approx(np.full(n, 0.02), abs=1e-12)
    assert moved["pitch_drivetrain"].mean() == pytest.approx(0.02, abs=1e-12)
    assert np.ptp(moved["pitch_drivetrain"]) == pytest.approx(0.2)    # moved, not rescaled
    assert "sign +1 assumed" in note
    assert _align_pitch(table.drop(columns="pitch_log"), np.ones(n, bool), ["nominal"])[1] is None


def test_the_table_adds_calibrated_rows_and_keeps_the_hand_written_section(tmp_path, capsys):
    mod = _table_script()
    todo = mod.pairs(tmp_path, ["lynx", "v9"])
    extra = mod.calibrated(todo, ["lynx_0_to_2"])
    assert [p["name"] for p in extra] == ["lynx_0_to_2_calibrated"] and extra[0]["calibrated"]
    assert "--calibrate-rider" in mod.command(extra[0], tmp_path, 20, 0)
    assert "--calibrate-rider" not in mod.command(todo[0], tmp_path, 20, 0)
    with pytest.raises(ValueError, match="blitz_1_to_2"):
        mod.calibrated(todo, ["blitz_1_to_2"])                    # not a pair of the wheels run
    res = [{"pair": extra[0], "error": "not run (no ride.json yet)"}]
    assert "0 → 2 (calibrated rider)" in mod.rows(res)[2]
    doc = tmp_path / "t.md"
    doc.write_text("# old\n\n| old table |\n\n## Reading the table (by hand)\n\n- kept words\n")
    mod.write_doc(doc, res, ["--out", "X"])
    text = doc.read_text()
    assert "old table" not in text and text.count("## Reading the table") == 1
    assert text.endswith("- kept words\n") and "(calibrated rider)" in text
    assert mod.main(["--out", str(tmp_path / "o"), "--data", str(tmp_path), "--pairs", "lynx",
                     "--calibrate-rider", "v9_0_to_1"]) == 2
    assert "--calibrate-rider v9_0_to_1: not a pair" in capsys.readouterr().err


def test_a_run_of_one_wheel_keeps_the_other_wheels_rows_and_commands(tmp_path):
    """``--pairs blitz --doc D`` replaces Blitz's rows of D, keeps every other row where it was
    (a pair this run did not reach keeps its earlier row), and lists both commands."""
    mod = _table_script()
    lynx, blitz = mod.pairs(tmp_path, ["lynx"]), mod.pairs(tmp_path, ["blitz"])
    bands = {"P_W": {"windows_s": [0.5, 6.0], "ratio_dB": [3.2, -1.4], "rms_dB": 2.47}}
    sim = {"steps": [{"step": "drivetrain", "ran": True, "heldout_rmse": {"P_W": 400.0},
                      "ratio_to_balance": 0.8, "target_ratio": 1.2, "heldout_bands": bands}],
           "falls": [], "notes": [], "scored_rows": 100, "pitch_scored_rows": 0}
    old = [{"pair": lynx[0], "json": {"heldout_error_augmented": 500.0, "simulation": sim}}] + \
          [{"pair": p, "error": "not run (no ride.json yet)"} for p in blitz[:2]]
    doc = tmp_path / "t.md"
    mod.write_doc(doc, old, ["--out", "A", "--pairs", "lynx,blitz"])
    doc.write_text(doc.read_text() + "\n## Reading the table (by hand)\n\n- kept words\n")
    new = [{"pair": blitz[0], "json": {"heldout_error_augmented": 1000.0, "simulation": sim}},
           {"pair": blitz[1], "error": "not run (no ride.json yet)"}]
    mod.write_doc(doc, new, ["--out", "B", "--pairs", "blitz"])
    text = doc.read_text()
    main_text, _, band_text = text.partition(mod.BAND_MARK)
    rows_ = [ln for ln in main_text.splitlines() if ln.startswith("| lynx") or ln.startswith("| blitz")]
    assert [r.split("|")[2].strip() for r in rows_] == ["0 → 2", "1 → 2", "1 → 4"]   # old order
    band_rows = [ln for ln in band_text.splitlines() if ln.startswith("| lynx") or ln.startswith("| blitz")]
    assert [r.split("|")[2].strip() for r in band_rows] == ["0 → 2", "1 → 2", "1 → 4"]
    assert "| – | – | – | P 2.5 dB (+3 … -1) |" in band_rows[0] and "P 2.5 dB (+3 … -1)" in band_rows[1]
    assert band_rows[2].count("–") == 4          # a pair not run has no bands
    assert "400 (**0.80**)" in rows_[0]                                           # lynx kept
    assert "1 → 2 | 1,000 |" in rows_[1] and "not run" in rows_[2]
    assert "--out A --pairs lynx,blitz" in text and "--out B --pairs blitz" in text
    assert "2 of 3 rows ran; 2 cells within the target (bold)" in text
    assert text.endswith("- kept words\n") and text.count("## Reading the table") == 1


def test_power_error_terms_names_a_missing_pair_and_exits_2(tmp_path):
    """studies/power_error_terms.py, run as a program: bad input is one line naming the file, exit 2."""
    code, err = _run_study("power_error_terms.py", str(tmp_path / "nope"), str(tmp_path / "held.csv"))
    assert code == 2 and "nope" in err and "ride.json" in err and "Traceback" not in err


def test_ride_step_ablation_refuses_an_unknown_variant_and_a_missing_pair(tmp_path):
    """studies/ride_step_ablation.py, run as a program: one line naming the bad input, exit 2."""
    code, err = _run_study("ride_step_ablation.py", str(tmp_path), "held.csv", "--variants", "faster")
    assert code == 2 and "--variants faster" in err
    code, err = _run_study("ride_step_ablation.py", str(tmp_path / "nope"), "held.csv")
    assert code == 2 and "ride.json" in err and "Traceback" not in err


def _run_study(name: str, *argv: str) -> tuple[int, str]:
    """A study of studies/ run as a program (tests never import studies/ or scripts/): (exit, stderr)."""
    import subprocess
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parents[3] / "studies" / name
    p = subprocess.run([sys.executable, str(path), *argv], capture_output=True, text=True, timeout=120)
    return p.returncode, p.stderr


def test_motor_from_law_inverts_the_steps_description():
    from euc_sim.rides.sim.sim_steps import SimStep, motor_from_law

    plain = MotorPD(Kp=5776.0, Kd=88.2, torque_limit=136.9)
    full = MotorPD(Kp=5776.0, Kd=88.2, torque_limit=250.0, tiltback_speed=14.1, tiltback_gain=8.5e-5,
                   voltage=151.2, back_emf=7.43, drop=0.123)
    weakened = replace(full, dead_time=0.03, flux_weakening=0.011, fw_speed=12.0)   # a drivetrain fit's extras
    for m in (plain, full, weakened):
        assert motor_from_law(sim_step_json(SimStep("drivetrain", "", motor=m))["motor"]) == m


def test_calibrated_riders_description_carries_his_fitted_values():
    """The step's JSON ``rider`` gives the bandwidth he was designed with (not only in ``what``)."""
    from euc_sim.rides.grids.signals import RideAssumptions
    from euc_sim.rides.rider.rider_params import rider_from
    from euc_sim.rides.sim.sim_steps import SimStep
    from euc_sim.rides.sim.simulate import ride_params

    fitted = {"delay": 0.281, "bandwidth": 0.101, "noise_std": 1.84}
    rider = rider_from(fitted, ride_params(RideAssumptions()), MotorPD())
    got = sim_step_json(SimStep("calibrated_rider", "", rider=rider, plan_window=6.0, rider_fit=fitted))["rider"]
    assert got == {"delay": pytest.approx(0.281), "noise_std": pytest.approx(1.84), "plan_window": 6.0,
                   "bandwidth": pytest.approx(0.101)}
    assert "bandwidth" not in sim_step_json(SimStep("nominal", "", rider=rider))["rider"]


def test_battery_power_adds_the_losses_in_both_regimes():
    """The energy balance: P = P₀ + M·(ẋ/R − γ̇) + k_cu·(M/R)², driving and braking alike."""
    from euc_sim.rides.sim.simulate import battery_power

    M, xd, gd, R = np.array([40.0, -40.0, 0.0]), np.array([5.0, 5.0, 5.0]), np.zeros(3), 0.25
    P = battery_power(M, xd, gd, R, copper=0.004, idle=20.0)
    mech = M * xd / R
    np.testing.assert_allclose(P, 20.0 + mech + 0.004 * (M / R) ** 2, rtol=1e-12)
    assert P[1] > mech[1] + 20.0            # braking returns less than the mechanical power
    np.testing.assert_allclose(battery_power(M, xd, gd, R), mech, rtol=1e-12)   # no loss: P_mech
