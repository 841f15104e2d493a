"""Closed-loop simulation: maneuvers on both engines, falls, recordings, the CLI."""

import hashlib
import json

import numpy as np
import pandas as pd
import pytest

from euc_sim.controllers.rider import Rider
from euc_sim.cli import main
from euc_sim.io import write_recording
from euc_sim.simulation.mocap import E_HEIGHT, RECORDING_COLUMNS, motion_capture
from euc_sim.model.parameters import TABLE3
from euc_sim.simulation.errors import FallError, SimulationError
from euc_sim.simulation.engine import default_rider, simulate
from euc_sim.simulation.maneuvers import load_speed_profile, make_maneuver

#: Short versions of every maneuver for the (slow) analytic engine: speed changes early.
SHORT = {
    "constant_speed": make_maneuver("constant_speed", v=2.0),
    "acceleration": make_maneuver("acceleration", v0=1.0, v1=3.0, start=0.3, ramp=2.0),
    "deceleration": make_maneuver("deceleration", v0=3.0, v1=1.0, start=0.3, ramp=2.0),
    "stop_and_go": make_maneuver("stop_and_go", v=1.0, start=0.5, ramp=1.2, hold=0.1, cycles=1),
}


@pytest.fixture(scope="module")
def decel_runs():
    """The paper's deceleration, 15 s, on both engines (noise off)."""
    return simulate("deceleration", 15.0), simulate("deceleration", 15.0, engine="analytic")


def test_engines_agree_over_15_s(decel_runs):
    mj, an = decel_runs
    assert len(mj) == len(an) == 15001
    err = np.max(np.abs(mj[["gamma", "phi"]].to_numpy() - an[["gamma", "phi"]].to_numpy()))
    assert err < 1e-4
    assert np.max(np.abs(mj["x"] - an["x"])) < 1e-4


def test_deceleration_leans_back_and_gamma_falls(decel_runs):
    run = decel_runs[0]
    ramp = run[(run.t > 3.5) & (run.t < 7.0)]          # v_ref falls from 4 to 0.5 m/s over 3-7 s
    assert ramp.phi.mean() < -0.05 and ramp.phi.min() < -0.15     # rider leans back (Fig. 6(d))
    assert ramp.gamma.mean() < -0.01                               # γ falls (Fig. 6(c))
    assert ramp.M_d.mean() < 0
    assert abs(run.x_dot.iloc[-1] - 0.5) < 0.05                    # and the speed follows
    assert abs(run.phi.iloc[-1]) < 0.01


@pytest.mark.parametrize("name", ["constant_speed", "acceleration", "deceleration", "stop_and_go"])
def test_every_maneuver_is_stable_on_mujoco(name):
    run = simulate(name, 15.0, rider=default_rider(noise_std=3.0), seed=2)
    assert np.all(np.isfinite(run.to_numpy()))
    assert run.phi.abs().max() < 0.4 and run.gamma.abs().max() < 0.15
    assert np.sqrt(np.mean((run.x_dot - run.v_ref) ** 2)) < 0.5       # it follows the plan
    if name != "stop_and_go":
        assert abs(run.x_dot.iloc[-3000:].mean() - run.v_ref.iloc[-1]) < 0.15


@pytest.mark.parametrize("name", ["constant_speed", "acceleration", "stop_and_go"])
def test_every_maneuver_is_stable_on_the_analytic_engine(name):
    run = simulate(SHORT[name], 3.0, engine="analytic", rider=default_rider(noise_std=3.0), seed=1)
    assert np.all(np.isfinite(run.to_numpy()))
    assert run.phi.abs().max() < 0.4 and run.gamma.abs().max() < 0.15
    if name == "acceleration":
        assert run[(run.t > 0.8) & (run.t < 2.0)].phi.mean() > 0.05    # lean forward to speed up


def test_contact_variant_runs_stop_and_go():
    run = simulate("stop_and_go", 8.0, variant="contact")
    assert run.phi.abs().max() < 0.4 and run.x_dot.max() > 2.0


def test_profile_maneuver_follows_the_csv(tmp_path):
    f = tmp_path / "v.csv"
    f.write_text("t,v\n0,1.0\n2,1.0\n5,3.0\n20,3.0\n")
    man = load_speed_profile(f)
    run = simulate(man, 10.0)
    assert abs(run.x_dot.iloc[-1] - 3.0) < 0.05
    assert run.v_ref.iloc[0] == pytest.approx(1.0)


def test_zero_rider_gains_fall_with_the_time_of_the_fall():
    with pytest.raises(FallError, match=r"fall at t = \d+\.\d{3} s: \|phi\| = .* exceeds the bound 0.7 rad") as e:
        simulate("constant_speed", 10.0, rider=Rider(K=(0.0,) * 5, noise_std=5.0), seed=3)
    assert isinstance(e.value, ValueError) and 0.0 < e.value.t < 10.0


@pytest.mark.parametrize("kw, match", [
    ({"maneuver": "wheelie"}, "unknown maneuver 'wheelie'; valid maneuvers: constant_speed, acceleration"),
    ({"maneuver": "profile"}, "needs a speed-profile CSV"),
    ({"engine": "bullet"}, "unknown engine 'bullet'; valid engines: mujoco, analytic"),
    ({"effects": {"gremlins": 1.0}}, "unknown effect 'gremlins'; valid effects: rolling_resistance"),
    ({"duration": -1.0}, "duration must be a positive number"),
    ({"engine": "analytic", "variant": "contact"}, "variant must be 'ideal'"),
])
def test_bad_requests_name_the_argument(kw, match):
    kw = {"maneuver": "constant_speed", "duration": 1.0, **kw}
    with pytest.raises(SimulationError, match=match):
        simulate(kw.pop("maneuver"), kw.pop("duration"), **kw)


def test_the_run_is_deterministic_and_seeded():
    r = default_rider(noise_std=3.0)
    a = simulate("constant_speed", 2.0, rider=r, seed=7)
    b = simulate("constant_speed", 2.0, rider=r, seed=7)
    c = simulate("constant_speed", 2.0, rider=r, seed=8)
    assert a.equals(b) and not a.equals(c)


# --- synthetic motion capture ---------------------------------------------------------
@pytest.fixture(scope="module")
def accel_run():
    return simulate("acceleration", 8.0, rider=default_rider(noise_std=3.0), seed=1)


def test_noise_free_capture_is_the_state_and_its_geometry(accel_run):
    rec = motion_capture(accel_run, TABLE3, noise="none")
    assert tuple(rec.columns) == RECORDING_COLUMNS
    assert np.allclose(np.diff(rec.t), 1 / 120) and rec.t.iloc[-1] == pytest.approx(8.0)
    on_grid = accel_run.iloc[::25].reset_index(drop=True)          # 1/120 s ≠ k ms except every 25 ms
    rows = rec.iloc[::3].reset_index(drop=True)
    np.testing.assert_allclose(rows.phi, on_grid.phi, atol=1e-12)
    np.testing.assert_allclose(rows.M_d, on_grid.M_d, atol=1e-12)
    d_CE = np.hypot(rec.E_X - rec.C_X, rec.E_Z - rec.C_Z)
    np.testing.assert_allclose(d_CE, E_HEIGHT, atol=1e-12)
    gx = rec.G_X - rec.C_X + TABLE3.l0 * np.sin(rec.gamma)
    gz = rec.G_Z - rec.C_Z + TABLE3.l0 * np.cos(rec.gamma)
    np.testing.assert_allclose(np.arctan2(gx, gz), rec.phi, atol=1e-12)
    np.testing.assert_allclose(rec.C_Z, TABLE3.R)


def test_paper_noise_has_the_stated_sigma(accel_run):
    clean = motion_capture(accel_run, TABLE3, noise="none")
    noisy = motion_capture(accel_run, TABLE3, noise="paper", seed=3)
    assert np.std(noisy.gamma - clean.gamma) == pytest.approx(np.radians(0.5), rel=0.1)
    assert np.std(noisy.E_X - clean.E_X) == pytest.approx(0.2e-3, rel=0.1)
    assert noisy.equals(motion_capture(accel_run, TABLE3, noise="paper", seed=3))


def test_sensor_time_offset_delays_the_rider_channel(accel_run):
    tau = 0.05                                      # 50 steps of 1 ms
    clean = motion_capture(accel_run, TABLE3, noise="none")
    late = motion_capture(accel_run, TABLE3, noise="none", effects={"sensor_time_offset": tau})
    rows = late.iloc[6::3]                          # t = 50, 75, 100 ... ms: t − τ on the 1 ms grid
    idx = np.rint((rows.t.to_numpy() - tau) / 1e-3).astype(int)
    np.testing.assert_allclose(rows.phi, accel_run.phi.to_numpy()[idx], atol=1e-12)
    np.testing.assert_allclose(late.gamma, clean.gamma, atol=0)
    assert late.phi.iloc[0] == clean.phi.iloc[0]    # held before the start
    assert np.max(np.abs(late.phi - clean.phi)) > 1e-3


def test_write_recording_parquet_and_csv(tmp_path, accel_run):
    rec = motion_capture(accel_run, TABLE3, noise="none")
    meta = {"params": {}, "maneuver": "acceleration", "source": "test"}
    write_recording(rec, tmp_path / "a.parquet", meta)
    back = pd.read_parquet(tmp_path / "a.parquet")
    assert back.equals(rec)
    write_recording(rec, tmp_path / "a.csv", meta, truth={"effects": {}})
    assert json.loads((tmp_path / "a.json").read_text())["maneuver"] == "acceleration"
    assert (tmp_path / "a.truth.json").exists()
    with pytest.raises(ValueError, match="must end in .csv or .parquet"):
        write_recording(rec, tmp_path / "a.txt", meta)
    bad = rec.copy()
    bad.loc[3, "phi"] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        write_recording(bad, tmp_path / "b.csv", meta)
    assert not (tmp_path / "b.csv").exists() and not (tmp_path / "b.json").exists()


# --- the command line -------------------------------------------------------------------
def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_simulate_same_seed_same_bytes(tmp_path):
    args = ["simulate", "--maneuver", "deceleration", "--duration", "6", "--effect", "rolling_resistance=0.02"]
    assert main(args + ["--seed", "1", "--out", str(tmp_path / "a.csv")]) == 0
    assert main(args + ["--seed", "1", "--out", str(tmp_path / "b.csv")]) == 0
    assert main(args + ["--seed", "2", "--out", str(tmp_path / "c.csv")]) == 0
    assert _digest(tmp_path / "a.csv") == _digest(tmp_path / "b.csv") != _digest(tmp_path / "c.csv")
    rec = pd.read_csv(tmp_path / "a.csv")
    assert {"t", "x", "gamma", "phi", "M_d", "M_h", "C_X", "E_Z", "G_X", "psi", "theta"} <= set(rec.columns)
    meta = json.loads((tmp_path / "a.json").read_text())
    assert meta["maneuver"] == "deceleration" and "h" not in meta["params"] and meta["source"]
    truth = json.loads((tmp_path / "a.truth.json").read_text())
    assert truth["effects"]["rolling_resistance"] == {"value": 0.02, "unit": "1"}
    assert truth["params"]["h"] == 0.6
    assert "0.02" not in (tmp_path / "a.json").read_text()


def test_simulate_hide_torques(tmp_path):
    assert main(["simulate", "--duration", "1", "--hide-torques", "--out", str(tmp_path / "h.csv")]) == 0
    cols = pd.read_csv(tmp_path / "h.csv").columns
    assert "M_d" not in cols and "M_h" not in cols and "phi" in cols


@pytest.mark.parametrize("extra, message", [
    (["--maneuver", "wheelie"], r"valid: constant_speed, acceleration, deceleration, stop_and_go, profile"),
    (["--effect", "gremlins=1"], r"unknown effect 'gremlins'; valid effects: rolling_resistance, aerodynamic_drag"),
    (["--effect", "road_slope"], r"NAME=VALUE"),
    (["--noise", "loud"], r"--noise: unknown value 'loud'; valid: paper, none"),
    (["--engine", "ode"], r"valid: mujoco, analytic"),
    (["--profile", "PROFILE_MISSING_V"], r"expected columns t, v; missing v"),
    (["--profile", "PROFILE_NOT_INCREASING"], r"t must be strictly increasing, got 2 then 1"),
    (["--maneuver", "profile"], r"--maneuver profile needs --profile FILE"),
    (["--duration", "0"], r"--duration: expected a number in \[0.1, 3600\] s, got 0"),
])
def test_simulate_bad_input_exit_2_nothing_written(tmp_path, capsys, extra, message):
    import re
    (tmp_path / "missing_v.csv").write_text("t,speed\n0,1\n1,2\n")
    (tmp_path / "not_inc.csv").write_text("t,v\n0,1\n2,2\n1,2\n")
    extra = [str(tmp_path / "missing_v.csv") if a == "PROFILE_MISSING_V" else
             str(tmp_path / "not_inc.csv") if a == "PROFILE_NOT_INCREASING" else a for a in extra]
    out = tmp_path / "out" / "r.csv"
    try:
        code = main(["simulate", "--duration", "1", "--out", str(out)] + extra)
    except SystemExit as stop:              # an option out of its range: argparse's exit
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and re.search(message, err), err
    assert not out.exists() and not list((tmp_path / "out").glob("*")) if (tmp_path / "out").exists() else True


def test_simulate_unwritable_output(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["simulate", "--duration", "1", "--out", str(blocker / "r.csv")]) == 2
    assert "cannot write" in capsys.readouterr().err
    assert blocker.read_text() == "x"


def test_simulate_fall_is_exit_2_without_files(tmp_path, capsys):
    out = tmp_path / "r.csv"
    # a rider who reacts after a full second cannot stay up
    assert main(["simulate", "--duration", "10", "--rider-delay", "1.0", "--out", str(out)]) == 2
    assert "fall at t = " in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_dataset_is_reproducible(tmp_path):
    from euc_sim.simulation.dataset import dataset_plan, run_dataset
    specs = dataset_plan(seed=0, duration=2.0, counts=(("constant_speed", 2), ("deceleration", 1)))
    a = run_dataset(tmp_path / "a", specs, workers=2, progress=False).ordered()
    b = run_dataset(tmp_path / "b", dataset_plan(seed=0, duration=2.0,
                                                 counts=(("constant_speed", 2), ("deceleration", 1))),
                    workers=1, progress=False).ordered()
    assert [p.name for p in a] == ["constant_speed_01.csv", "constant_speed_02.csv", "deceleration_01.csv"]
    assert [_digest(p) for p in a] == [_digest(p) for p in b]
    assert _digest(a[0]) != _digest(a[1])
    assert json.loads((tmp_path / "a" / "dataset.json").read_text())["recordings"][2] == "deceleration_01.csv"
    meta = json.loads((tmp_path / "a" / "deceleration_01.json").read_text())
    assert make_maneuver(meta["maneuver"], **meta["maneuver_options"]) == specs[2].maneuver


def test_external_force_hook_acts_alike_in_both_engines():
    """An out-of-catalog push F(t) at G: both engines see the same physics."""
    from euc_sim.simulation.effects import PeriodicPush
    from euc_sim.simulation.engine import simulate
    push = PeriodicPush(amplitude=40.0, frequency=0.5)
    a = simulate("constant_speed", 3.0, external_force=push)
    b = simulate("constant_speed", 3.0, external_force=push, engine="analytic")
    still = simulate("constant_speed", 3.0)
    assert np.max(np.abs(a["phi"] - still["phi"])) > 1e-3        # the push moved the rider
    assert np.max(np.abs(a[["gamma", "phi"]].to_numpy() - b[["gamma", "phi"]].to_numpy())) < 1e-6
    with pytest.raises(ValueError, match="external_force must be a callable"):
        simulate("constant_speed", 1.0, external_force=3.0)
