"""Twin experiments: simulate with known h and gains, recover them from the recording."""

from __future__ import annotations

import json
import re

import numpy as np
import pandas as pd
import pytest

import idsim
from euc_sim.model import analytic
from euc_sim.cli import main
from euc_sim.identification.torques import MODELS, TORQUE_COLUMNS, torques
from euc_sim.identification.base_params import base_groups, base_regressor, identify_base_parameters
from euc_sim.identification.controller_fit import fit_delayed_law, identify_controller, identify_rider_delay
from euc_sim.identification.h_fit import MIN_RISE, identify_h, residual_poly
from euc_sim.io import write_recording
from euc_sim.model.mujoco_model import EucMujoco
from euc_sim.model.parameters import TABLE3, Params
from euc_sim.identification.processing import Smoothing, kinematics
from euc_sim.simulation.engine import simulate

EXACT = Smoothing(window=9 / 120, order=6, term_sigma=0.0)   # noise-free: near-exact derivatives
H_TRUE = TABLE3.h


def _fit(rec, smoothing=Smoothing(), model="3dof", **kw):
    return identify_h([residual_poly(kinematics(rec, TABLE3, smoothing), TABLE3, model)], **kw)


# --- the algebra ------------------------------------------------------------------------------
@pytest.mark.parametrize("model", MODELS)
def test_residual_poly_reproduces_the_analytic_torques(model):
    rng = np.random.default_rng(4)
    n = 400
    q = np.column_stack([rng.normal(size=n), rng.uniform(-0.3, 0.3, n), rng.uniform(-0.5, 0.5, n)])
    qd, qdd = rng.normal(size=(2, n, 3))
    kin = kinematics(pd.DataFrame({"t": np.arange(n) / 120, "x": q[:, 0], "gamma": q[:, 1],
                                   "phi": q[:, 2]}), TABLE3, EXACT)
    kin = type(kin)(t=kin.t, q=q, qd=qd, qdd=qdd, extra={}, smoothing=EXACT)
    rp = residual_poly(kin, TABLE3, model)
    f1, f2 = ((analytic.driving_torque_1, analytic.driving_torque_2) if model == "3dof" else
              (analytic.reduced_driving_torque_1, analytic.reduced_driving_torque_2))
    for h in (0.23, 0.6, 1.37):
        p = TABLE3.replace(h=h)
        want = (f1(p, q, qd, qdd) - f2(p, q, qd, qdd))[kin.interior]
        np.testing.assert_allclose(rp.residual(h), want, rtol=1e-9, atol=1e-9)


def test_base_regressor_reproduces_inverse_dynamics():
    rng = np.random.default_rng(5)
    q, qd, qdd = rng.normal(size=(3, 200, 3))
    for _ in range(5):
        p = Params(**{k: v * rng.uniform(0.5, 1.5) for k, v in TABLE3.as_dict().items()})
        got = base_regressor(q, qd, qdd, p.g) @ base_groups(p)
        np.testing.assert_allclose(got, analytic.inverse_dynamics(p, q, qd, qdd), atol=1e-10)


# --- torques: four ways agree on noise-free simulated data -------------------------------------
def test_torques_agree_with_mj_inverse_and_the_true_torque():
    """M_d,1, M_d,2, mj_inverse and the simulation's M_d to 1e-6 N·m.

    q̈ comes from the simulator's own velocity samples: over each control step the
    torques are held, so (q̇_{k+1} − q̇_k)/dt is the acceleration at the step's midpoint
    to O(dt²).
    """
    dt = 1.25e-4
    run = simulate("deceleration", 4.0, dt=dt)
    Q = run[["x", "gamma", "phi"]].to_numpy()
    V = run[["x_dot", "gamma_dot", "phi_dot"]].to_numpy()
    q, qd, qdd = 0.5 * (Q[1:] + Q[:-1]), 0.5 * (V[1:] + V[:-1]), np.diff(V, axis=0) / dt
    M_d, M_h = run["M_d"].to_numpy()[:-1], run["M_h"].to_numpy()[:-1]
    assert np.abs(M_d).max() > 5.0                       # the ride actually brakes
    p = TABLE3
    assert np.abs(analytic.driving_torque_1(p, q, qd, qdd) - M_d).max() < 1e-6
    assert np.abs(analytic.driving_torque_2(p, q, qd, qdd) - M_d).max() < 1e-6
    assert np.abs(analytic.rider_torque(p, q, qd, qdd) - M_h).max() < 1e-6
    sim = EucMujoco(p)
    idx = np.arange(0, len(q), 97)
    mj = np.array([sim.inverse(q[i], qd[i], qdd[i]) for i in idx])
    assert np.abs(p.R * mj[:, 0] - M_d[idx]).max() < 1e-6
    assert np.abs(-mj[:, 2] - M_h[idx]).max() < 1e-6


def test_torques_from_a_120hz_recording():
    """From positions alone, at 120 Hz, the torques of the 1 kHz zero-order hold are seen
    to 0.047 N·m (M_d, of 30 N·m; median 4e-5) and 0.13 N·m (M_h), the worst at the
    kinks of the planned speed ramp; the reduced model misses by up to 0.85 N·m."""
    rec = idsim.recording("deceleration", noise="none")
    kin = kinematics(rec, TABLE3, EXACT)
    T = torques(kin, TABLE3)
    assert list(T.columns) == list(TORQUE_COLUMNS)
    sl = kin.interior
    err = {col: np.abs(T[col].to_numpy()[sl] - rec["M_d"].to_numpy()[sl]).max()
           for col in ("M_d1", "M_d2", "M_d1_2dof", "M_d2_2dof")}
    assert err["M_d1"] < 0.05 and err["M_d2"] < 0.05, err
    assert min(err["M_d1_2dof"], err["M_d2_2dof"]) > 10 * max(err["M_d1"], err["M_d2"]), err
    assert np.abs(T["M_h"].to_numpy()[sl] - rec["M_h"].to_numpy()[sl]).max() < 0.2


# --- identifying h -------------------------------------------------------------------------------
def test_noise_free_recording_gives_the_true_h():
    fit = _fit(idsim.recording("deceleration", noise="none"), EXACT)
    assert abs(fit.h - H_TRUE) < 1e-6
    # without noise the interval collapses to round-off: a basic (reverse-percentile)
    # interval that narrow need not straddle its own estimate, so test its precision
    lo, hi = fit.h_ci95
    assert fit.identifiable and hi - lo < 1e-6
    assert abs(lo - H_TRUE) < 1e-6 and abs(hi - H_TRUE) < 1e-6


@pytest.mark.parametrize("maneuver", ["deceleration", "acceleration"])
def test_paper_noise_gives_h_within_2cm(maneuver):
    rec = idsim.recording(maneuver, noise="paper", seed=1)
    fit = _fit(rec)
    assert abs(fit.h - H_TRUE) < 0.02, fit.h
    assert fit.identifiable
    paper = _fit(rec, Smoothing(method="savgol"))       # NOTES.md item 4: the paper's recipe is biased
    assert abs(paper.h - H_TRUE) > abs(fit.h - H_TRUE)


def test_constant_speed_is_flagged():
    rec = idsim.recording("constant_speed", noise="paper", seed=1)
    for model in MODELS:
        fit = _fit(rec, model=model)
        assert not fit.identifiable, (model, fit.h, fit.h_ci95, fit.reason)
    # a rider swaying by ~1.5° (motor noise 1 N·m): an interior minimum, but a flat curve
    from euc_sim.simulation.mocap import motion_capture
    from euc_sim.simulation.engine import default_rider

    run = simulate("constant_speed", 20.0, rider=default_rider(noise_std=1.0), seed=1)
    for seed in (1, 2):
        fit = _fit(motion_capture(run, TABLE3, noise="paper", seed=seed), seed=seed)
        assert not fit.identifiable and fit.flatness < MIN_RISE, (fit.h, fit.flatness, fit.reason)


def test_verdict_needs_a_real_interval():
    """Too few replicates or blocks: never "identifiable", however sharp the curve looks."""
    rec = idsim.recording("deceleration", noise="paper", seed=1)
    assert _fit(rec).identifiable
    for kw, why in (({"n_boot": 0}, "0 bootstrap replicates are too few"),
                    ({"n_boot": 10}, "10 bootstrap replicates are too few"),
                    ({"block": 1000.0}, r"only 1 block\(s\)")):
        fit = _fit(rec, **kw)
        assert not fit.identifiable, kw
        assert re.search(why, fit.reason), fit.reason


def test_3dof_world_favours_the_3dof_model():
    for noise in ("none", "paper"):
        rec = idsim.recording("deceleration", noise=noise, seed=2)
        sm = EXACT if noise == "none" else Smoothing()
        f3, f2 = _fit(rec, sm, "3dof", n_boot=0), _fit(rec, sm, "2dof", n_boot=0)
        assert f3.rmse < f2.rmse, (noise, f3.rmse, f2.rmse)


def test_bootstrap_is_seeded():
    rec = idsim.recording("acceleration", noise="paper", seed=4)
    a, b = _fit(rec, seed=7), _fit(rec, seed=7)
    assert a.h_ci95 == b.h_ci95
    assert a.h_ci95[0] < a.h < a.h_ci95[1]


# --- beyond the paper -------------------------------------------------------------------------------
def test_controller_gains_recovered():
    clean = kinematics(idsim.recording("deceleration", noise="none"), TABLE3)
    g = identify_controller(clean, TABLE3).gains
    assert abs(g["gamma"] / idsim.KP_TRUE - 1) < 0.1 and abs(g["gamma_d"] / idsim.KD_TRUE - 1) < 0.1
    noisy = kinematics(idsim.recording("deceleration", noise="paper", seed=1), TABLE3)
    g = identify_controller(noisy, TABLE3).gains
    assert abs(g["gamma"] / idsim.KP_TRUE - 1) < 0.1, g
    # K_d needs pooling at the paper's noise: one 15 s ride scatters it by ±14 % (1 sd)
    pooled = [kinematics(idsim.recording(m, noise="paper", seed=1), TABLE3)
              for m in ("deceleration", "acceleration", "stop_and_go")]
    g = identify_controller(pooled, TABLE3).gains
    assert abs(g["gamma"] / idsim.KP_TRUE - 1) < 0.1 and abs(g["gamma_d"] / idsim.KD_TRUE - 1) < 0.1, g


def test_delayed_law_recovers_a_known_delay():
    dt = 1 / 120
    t = np.arange(2400) * dt
    phi = 0.05 * np.sin(1.3 * t) + 0.02 * np.sin(3.1 * t + 1)
    phi_d = 0.065 * np.cos(1.3 * t) + 0.062 * np.cos(3.1 * t + 1)
    n = 18                                               # 0.15 s
    X = np.column_stack([phi, phi_d, np.ones_like(t)])
    y = np.empty_like(t)
    y[n:] = X[:-n] @ np.array([700.0, 120.0, 1.5])
    y[:n] = y[n]
    fit = fit_delayed_law(y, X, dt, 0.5)
    assert fit["delay"] == pytest.approx(0.15) and not fit["at_bound"]
    np.testing.assert_allclose(fit["coef"], [700.0, 120.0, 1.5], rtol=1e-6)
    short = fit_delayed_law(y, X, dt, 0.1)               # the true delay lies beyond the search
    assert short["delay"] == pytest.approx(0.1) and short["at_bound"]


def test_h_on_its_search_bound_is_flagged():
    """h searched below the true 0.6 m ends on the bound: "h" (and its clipped interval) listed."""
    from euc_sim.identification.h_fit import identify_h, residual_poly

    kin = kinematics(idsim.recording("deceleration", noise="paper", seed=1), TABLE3)
    poly = residual_poly(kin, TABLE3, "3dof")
    free = identify_h([poly], bounds=(0.1, 1.5), n_boot=60)
    assert abs(free.h - 0.6) < 0.1 and free.at_bound() == []
    capped = identify_h([poly], bounds=(0.1, 0.45), n_boot=60)
    assert capped.h > 0.45 - 0.04 and capped.at_bound() == ["h", "h_ci95"]


def test_rider_delay_runs_on_simulated_data():
    kin = kinematics(idsim.recording("deceleration", noise="paper", seed=1), TABLE3)
    fit = identify_rider_delay(kin, TABLE3)
    assert 0.0 <= fit.delay <= 0.5 and fit.r2 > 0.9


def test_base_parameters_with_known_torques():
    """Groups flagged identifiable are accurate; the weak ones are flagged."""
    rec = idsim.recording("deceleration", noise="none")
    kin = kinematics(rec, TABLE3)
    both = identify_base_parameters(kin, rec["M_d"], rec["M_h"], TABLE3)
    only_md = identify_base_parameters(kin, rec["M_d"], None, TABLE3)
    idx = {n: i for i, n in enumerate(both.names)}
    for fit, must in ((both, ("m_11", "m0h0 - ml0", "mh", "mhl0", "J + mh²")),
                      (only_md, ("m_11", "m0h0 - ml0", "mh", "J + mh²"))):
        ok = fit.identifiable
        assert all(ok[idx[n]] for n in must), (fit.names, ok)
        np.testing.assert_allclose(fit.estimate[ok], fit.nominal[ok], rtol=0.01)
        assert not ok[idx["J0 + m0h0² + ml0²"]]
    # with M_d alone m·h·l0 is off by 7 % and flagged; the problem is worse conditioned
    assert not only_md.identifiable[idx["mhl0"]]
    assert only_md.condition_number > 10 * both.condition_number
    noisy = kinematics(idsim.recording("deceleration", noise="paper", seed=1), TABLE3)
    fit = identify_base_parameters(noisy, rec["M_d"], rec["M_h"], TABLE3)
    ok = fit.identifiable
    assert ok[idx["m_11"]] and ok[idx["mh"]] and ok[idx["J + mh²"]]
    np.testing.assert_allclose(fit.estimate[ok], fit.nominal[ok], rtol=0.05)


# --- the commands ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def written(tmp_path_factory):
    d = tmp_path_factory.mktemp("recs")
    paths = []
    for m in ("deceleration", "acceleration"):
        rec = idsim.recording(m, noise="paper", seed=1).drop(columns=["M_d", "M_h"])
        paths.append(write_recording(rec, d / f"{m}.csv", {"maneuver": m}))
    return d, paths


def test_cli_identify_writes_the_contract_json(written, capsys):
    d, paths = written
    code = main(["identify", *map(str, paths), "--json", str(d / "id.json"),
                 "--report", str(d / "figs"), "--n-boot", "100"])
    assert code == 0, capsys.readouterr().err
    out = json.loads((d / "id.json").read_text())
    assert out["recordings"] == [str(p) for p in paths]
    for model in MODELS:
        m = out["models"][model]
        assert {"h", "h_ci95", "rmse", "identifiable"} <= set(m)
        assert len(m["h_ci95"]) == 2 and isinstance(m["identifiable"], bool)
    assert abs(out["models"]["3dof"]["h"] - H_TRUE) < 0.02
    assert [r["recording"] for r in out["per_recording"]] == [str(p) for p in paths]
    for f in out["figures"]:
        with open(f, "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    assert len(out["figures"]) == 3
    assert {"gamma", "gamma_d"} == set(out["controller"]["gains"])


def test_cli_identify_says_which_fits_end_on_a_bound(written, capsys):
    """Issue 19, item 3: h searched up to 0.45 m (truth 0.6 m) is a bound, said in print and JSON."""
    d, paths = written
    assert main(["identify", str(paths[0]), "--json", str(d / "free.json"), "--n-boot", "60"]) == 0
    free = json.loads((d / "free.json").read_text())
    out = capsys.readouterr().out
    assert [k for k in free["at_bound"] if not k.endswith("rider.delay")] == [] and "h lies" not in out
    assert main(["identify", *map(str, paths), "--json", str(d / "capped.json"), "--n-boot", "60",
                 "--h-max", "0.45"]) == 0
    capped = json.loads((d / "capped.json").read_text())
    out = capsys.readouterr().out
    for where in ("per_recording[0].", "per_recording[1].", ""):
        for model in MODELS:
            assert f"{where}models.{model}.h" in capped["at_bound"], (where, model, capped["at_bound"])
    assert "WARNING: pooled 3dof: h = 0.4" in out and "lies on the search bound [0.1, 0.45] m" in out
    for key in capped["at_bound"]:                       # each path names a value in the JSON
        node = capped
        for part in key.replace("[", ".").replace("]", "").split("."):
            node = node[int(part)] if part.isdigit() else node[part]
        assert node is not None


def test_cli_torques_columns(written, capsys):
    d, paths = written
    assert main(["torques", str(paths[0]), "--h", "0.6", "--out", str(d / "T.csv")]) == 0
    T = pd.read_csv(d / "T.csv")
    assert list(T.columns) == [*TORQUE_COLUMNS, "valid"] and len(T) == 1801   # CONTRACT columns first


def test_cli_bad_option_one_line(written, capsys):
    d, paths = written
    code = main(["identify", str(paths[0]), "--h-min", "0.9", "--h-max", "0.5"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "--h-min" in err
