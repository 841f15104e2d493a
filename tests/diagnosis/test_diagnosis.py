"""euc-sim diagnose: the residual, the candidate physics, and a small blind study.

The blind study here is a small version of ``scripts/tables/blind_study.py``: recordings
made by the closed-loop simulator with one effect concealed (truth only in
NAME.truth.json), diagnosed from the CSV and its sidecar alone.  Its seed (2024) was
fixed before the first run and is not tuned.
"""

from __future__ import annotations

import json
import shutil
import warnings

import numpy as np
import pandas as pd
import pytest

from euc_sim.model import analytic
from euc_sim.diagnosis import candidates, localise, pipeline as diagnosis, prepare, residual
from euc_sim.diagnosis.common import THRESHOLDS
from euc_sim.simulation import effects
from euc_sim.model.parameters import TABLE3

import blind_scoring as SCORING  # the blind study's code, in scripts/tables/
import blind_study as BLIND

SEED = 2024
DURATION = 15.0

#: (effect, value, maneuver, hide torques); magnitudes inside the plausible ranges
CASES = [
    ("rolling_resistance", 0.025, "stop_and_go", True),
    ("aerodynamic_drag", 0.45, "deceleration", True),
    ("road_slope", -0.035, "acceleration", True),
    ("sensor_time_offset", 0.06, "stop_and_go", True),
    ("wheel_bearing_friction", 1.5, "deceleration", False),
    ("rider_mass", 88.0, "acceleration", False),
    (None, 0.0, "deceleration", True),
    (None, 0.0, "stop_and_go", True),
    (None, 0.0, "acceleration", False),
    ("push", 0.0, "deceleration", True),
]


def _case(i, effect, value, maneuver, hide):
    rng = np.random.default_rng([SEED, i])
    push = None
    kind = "effect" if effect else "null"
    if effect == "push":
        kind, effect, push = "push", None, {"amplitude": 25.0, "frequency": 0.6}
    return {"name": f"t{i:02d}", "kind": kind, "effect": effect, "value": value, "maneuver": maneuver,
            "options": BLIND.maneuver_options(maneuver, rng), "hide_torques": hide, "push": push,
            "seed": int(rng.integers(1, 2**31 - 1)), "duration": DURATION}


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("blind")
    cases = [_case(i, *c) for i, c in enumerate(CASES)]
    results = BLIND.run(cases, out, workers=2, progress=lambda s: None)
    return out, {r["case"]["name"]: r for r in results}


def _by(study, effect=None, kind="effect"):
    return [r for r in study[1].values() if r["case"]["kind"] == kind
            and (effect is None or r["case"]["effect"] == effect)]


# --- the residual and the candidate physics --------------------------------------------
@pytest.fixture(scope="module")
def noise_free(tmp_path_factory):
    """A noise-free deceleration with rolling resistance, torques recorded."""
    from euc_sim import io
    from euc_sim.simulation import dataset
    from euc_sim.simulation.maneuvers import make_maneuver
    spec = dataset.RecordingSpec("nf", make_maneuver("deceleration"), 12.0, 3,
                                 effects=(("rolling_resistance", 0.02),), noise="none")
    rec, meta, truth = dataset.simulated_recording(spec)
    return io.write_recording(rec, tmp_path_factory.mktemp("nf") / "nf.csv", meta, truth)


def test_residual_matches_the_paper_torques_and_the_catalog_term(noise_free):
    prep = prepare.prepare(noise_free)
    model = residual.residual_model(prep)
    k = prep.keep
    p = TABLE3
    # the closed form in h is eqs. (9)-(10), term-filtered (identification.torques filters
    # M_d,1 and M_d,2 themselves, the closed form their numerator over a common
    # denominator: the two differ by the filter's action on the slowly varying κ, a few
    # mN·m against a residual of about 1 N·m here)
    from euc_sim.identification.torques import torques
    tq = torques(prep.kin, p.replace(h=0.6))
    assert np.max(np.abs(model.kinematic(0.6) - (tq["M_d1"] - tq["M_d2"]).to_numpy()[k])) < 0.01
    # the rolling-resistance term explains the residual: θ ≈ C_rr, RMSE ≪ the effect
    prob, info = candidates.build_problem(prep, 0.6)
    from euc_sim.identification import regression as reg
    f = reg.fit_set(prob, ("rolling_resistance",))
    assert f.theta["rolling_resistance"][0] == pytest.approx(0.02, rel=0.03)
    assert f.h == pytest.approx(0.6, abs=0.01)
    assert f.rmse < 0.1 * reg.fit_set(prob, ()).rmse


def test_bearing_friction_cancels_from_the_kinematic_residual():
    """An internal torque: zero moment about P, but present in the wheel row."""
    rng = np.random.default_rng(0)
    q = rng.normal(0, 0.1, (50, 3))
    qd = rng.normal(0, 1.0, (50, 3))
    Q = effects.generalized_force("wheel_bearing_friction", 2.0, TABLE3, q, qd)
    assert np.max(np.abs(analytic.kinematic_residual(TABLE3, q, Q))) < 1e-12
    assert np.max(np.abs(TABLE3.R * Q[:, 0])) > 1.0


def test_visibility_depends_on_the_columns():
    v = candidates.visibility(["t", "x", "gamma", "phi"])
    assert not v["wheel_bearing_friction"]["visible"]
    assert not v["rider_mass"]["visible"]
    assert not v["lateral_dynamics"]["visible"]
    assert v["rolling_resistance"]["visible"]
    w = candidates.visibility(["t", "x", "gamma", "phi", "M_d", "psi", "theta"])
    assert w["wheel_bearing_friction"]["visible"] and w["rider_mass"]["visible"]
    assert w["lateral_dynamics"]["visible"]


def test_localise_finds_the_window_and_the_correlation():
    t = np.arange(0, 20, 1 / 30)
    speed = 2 + np.sin(t)
    r = 0.05 * np.sin(7 * t) + np.where((t > 8) & (t < 11), 1.0, 0.0) * speed
    loc = localise.localise(t, r, {"speed": speed, "other": np.cos(3 * t)})
    assert len(loc["windows"]) == 1
    a, b = loc["windows"][0]
    assert 7.0 < a < 8.8 and 10.2 < b < 12.0
    assert loc["share"] > 0.9
    with pytest.raises(ValueError, match="same length"):
        localise.localise(t, r[:-1], {})


# --- the small blind study -------------------------------------------------------------
@pytest.mark.parametrize("effect", ["rolling_resistance", "aerodynamic_drag", "road_slope",
                                    "sensor_time_offset", "wheel_bearing_friction", "rider_mass"])
def test_blind_right_effect_first_estimate_and_improvement(study, effect):
    (r,) = _by(study, effect)
    res = r["result"]
    assert res["decidable"]
    first = res["effects"][0]
    names = {first["name"], *first["aliases"]}
    if effect in ("rolling_resistance", "road_slope"):
        assert effect in names          # NOTES fact 5: they may alias; both must be reported
    else:
        assert first["name"] == effect
    for a in set(first["aliases"]) & {"rolling_resistance", "road_slope"}:
        assert set(first["alias_estimates"][a]) == {"estimate", "unit", "ci95"}
    # named by its alias: the identified constant force mapped to the concealed effect's unit
    est = first if first["name"] == effect else first["alias_estimates"][effect]
    assert est["estimate"] == pytest.approx(r["case"]["value"], rel=0.25)
    lo, hi = est["ci95"]
    assert lo < est["estimate"] < hi
    assert res["augmented_rmse"] <= 0.5 * res["nominal_rmse"]


def test_blind_nulls_name_nothing(study):
    nulls = _by(study, kind="null")
    assert len(nulls) == 3
    for r in nulls:
        assert r["result"]["effects"] == [], r["case"]["name"]
        assert r["result"]["unexplained"] is False


def test_blind_out_of_catalog_push_is_unexplained_and_unnamed(study):
    (r,) = _by(study, kind="push")
    assert r["result"]["unexplained"] is True
    assert r["result"]["effects"] == []


def test_diagnose_never_reads_the_truth(study, tmp_path):
    out, results = study
    src = out / "t01.csv"
    shutil.copy(src, tmp_path / "t01.csv")
    shutil.copy(out / "t01.json", tmp_path / "t01.json")
    (tmp_path / "t01.truth.json").write_text('{"effects": {"road_slope": {"value": 0.05}}}')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnosis.json_view(diagnosis.diagnose(tmp_path / "t01.csv", resimulate=False))
    ref = json.loads((out / "t01.diagnosis.json").read_text())
    assert [e["name"] for e in res["effects"]] == [e["name"] for e in ref["effects"]]
    assert res["nominal_rmse"] == pytest.approx(ref["nominal_rmse"], rel=1e-9)


def test_cli_diagnose_writes_contract_json_and_report(study, tmp_path, capsys):
    from euc_sim.cli import main
    out, _ = study
    rc = main(["diagnose", str(out / "t01.csv"), "--json", str(tmp_path / "d.json"),
               "--report", str(tmp_path / "rep")])
    assert rc == 0
    d = json.loads((tmp_path / "d.json").read_text())
    for key in ("recording", "nominal_rmse", "effects", "unexplained", "windows"):
        assert key in d
    for e in d["effects"]:
        assert set(e) >= {"name", "estimate", "unit", "ci95", "rmse_after", "aliases", "evidence"}
    page = (tmp_path / "rep" / "index.md").read_text()
    for png in ("residual.png", "terms.png", "before_after.png", "resimulation.png"):
        assert (tmp_path / "rep" / png).stat().st_size > 10_000
        assert png in page
    assert "aerodynamic_drag" in capsys.readouterr().out


def test_cli_diagnose_bad_input_exit_2(tmp_path, capsys):
    from euc_sim.cli import main
    rc = main(["diagnose", str(tmp_path / "missing.csv")])
    assert rc == 2
    assert "missing.csv" in capsys.readouterr().err
    bad = tmp_path / "short.csv"
    pd.DataFrame({"t": np.arange(50) / 120, "x": np.zeros(50), "gamma": np.zeros(50),
                  "phi": np.zeros(50)}).to_csv(bad, index=False)
    assert main(["diagnose", str(bad), "--json", str(tmp_path / "o.json")]) == 2
    assert not (tmp_path / "o.json").exists()


def test_too_little_excitation_is_said_not_guessed():
    """Constant speed, a still rider: h and a constant force cannot be told apart."""
    from euc_sim.simulation import dataset
    from euc_sim.simulation.maneuvers import make_maneuver
    spec = dataset.RecordingSpec("still", make_maneuver("constant_speed", v=3.0), 15.0, 11,
                                 effects=(("rolling_resistance", 0.02),), hide_torques=True)
    rec, meta, _ = dataset.simulated_recording(spec)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnosis.diagnose(rec, meta=meta, resimulate=False)
    assert res["decidable"] is False
    assert res["verdict"] == "too little excitation or too much noise to decide"
    assert res["effects"] == [] and res["unexplained"] is False
    assert any("not identifiable" in n for n in res["notes"])


def test_motion_capture_columns_alone_give_the_same_diagnosis(study, tmp_path):
    """A file with only C/E/G positions and Euler angles (CONTRACT's motion-capture
    level): Section 2 gives x, φ; the noise floor is estimated from the raw columns."""
    out, _ = study
    df = pd.read_csv(out / "t01.csv").drop(columns=["x", "phi"])
    df.to_csv(tmp_path / "m.csv", index=False)
    shutil.copy(out / "t01.json", tmp_path / "m.json")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnosis.diagnose(tmp_path / "m.csv", resimulate=False)
    assert [e["name"] for e in res["effects"]][:1] == ["aerodynamic_drag"]
    assert res["unexplained"] is False
    assert res["noise_sd"]["phi"] == pytest.approx(np.radians(0.5), rel=0.3)


def test_null_recordings_stay_below_the_acceptance_thresholds(study):
    """The calibration statistic: on every null, even the strongest candidate of the
    first step is refused by the BIC (the test that separates nulls, see Thresholds)."""
    th = THRESHOLDS
    nulls = _by(study, kind="null")
    assert nulls
    for r in nulls:
        hist = r["result"]["history"]
        best = BLIND.first_step_best(hist)
        assert best["bic_drop"] < th.min_bic_drop, (r["case"]["name"], best)
        assert best["bic_drop"] == pytest.approx(hist[0]["trials"][0]["bic"]
                                                 - min(d["bic"] for d in hist[1]["trials"]))


def test_diagnose_does_not_modify_its_input(study):
    out, _ = study
    df = pd.read_csv(out / "t07.csv")
    before = df.copy()
    meta = json.loads((out / "t07.json").read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnosis.diagnose(df, meta=meta, resimulate=False)
    pd.testing.assert_frame_equal(df, before)
    assert res["effects"] == []


def test_blind_study_scores_an_alias_pair_on_its_mapped_estimate_and_a_declared_blind_drift():
    case = {"effect": "rolling_resistance", "value": 0.033, "kind": "effect"}
    first = {"name": "road_slope", "estimate": 0.010, "ci95": [0.0095, 0.0105], "aliases": ["rolling_resistance"],
             "alias_estimates": {"rolling_resistance": {"estimate": 0.0327, "unit": "1", "ci95": [0.031, 0.0343]}}}
    res = {"decidable": True, "effects": [first]}
    assert SCORING.truth_estimate(case, res)["estimate"] == 0.0327
    assert SCORING.truth_estimate({**case, "effect": "aerodynamic_drag"}, res) is None
    drift = {"effect": "cog_height_drift", "value": 0.1, "kind": "effect", "duration": 20.0,
             "drift_shape": {"kind": "dip", "start": 11.0, "length": 3.0, "sign": 1.0}}
    lim = {"cog_height_drift": {"blind_windows": [[1.0, 4.0], [9.5, 16.0]], "analysed_span": [1.0, 19.0]}}
    quiet = {"decidable": True, "effects": [], "limits": lim}
    assert SCORING.declared_blind(drift, quiet)
    assert not SCORING.declared_blind({**drift, "drift_shape": {**drift["drift_shape"], "start": 14.0}}, quiet)
    ramp = {**drift, "drift_shape": {"kind": "ramp", "start": 12.0, "length": 2.0, "sign": 1.0}}
    assert not SCORING.declared_blind(ramp, quiet)        # h stays changed to the end, outside the window
    named = {**quiet, "effects": [{"name": "road_slope"}]}
    assert not SCORING.declared_blind(drift, named)       # something was named: not a declaration


def test_one_floor_ratio_named_wherever_it_is_printed(study):
    """Issue 19, item 4: the summary's "× the noise floor" is the JSON's ``heldout_over_floor``
    (the reported model's held-out RMSE over the floor); the unexplained test's own ratio is
    named as the one that counts tentative effects too."""
    from euc_sim.diagnosis.common import h_at_bound
    from euc_sim.report.diagnosis import summary

    out, results = study
    for name, r in results.items():
        if "result" not in r:
            continue
        res = json.loads((out / f"{name}.diagnosis.json").read_text())     # the whole JSON
        ratio = res["augmented_rmse"] / res["noise_floor"]
        assert res["heldout_over_floor"] == pytest.approx(ratio, rel=1e-12), name
        if not res["tentative"]:
            assert res["generic"]["floor_ratio"] == pytest.approx(ratio, rel=1e-12), name
        text = summary(res)
        assert f"held-out RMSE over the noise floor {ratio:.1f}×)" in text, name
        if res["unexplained"]:
            whose = "the tentative ones too" if res["tentative"] else "with the accepted effects"
            assert f"{res['generic']['floor_ratio']:.1f}× {whose}" in text, name
        # issue 19, item 3: an h on its search bound is listed and marked
        for key in ("h_nominal", "h_augmented"):
            assert (key in res["at_bound"]) == h_at_bound(res[key]), (name, key)


def test_the_summary_marks_quantities_on_their_search_bound():
    from euc_sim.report.diagnosis import summary

    eff = {"name": "sensor_time_offset", "estimate": 0.05, "unit": "s", "ci95": [0.04, 0.06],
           "aliases": [], "rmse_after": 0.2, "evidence": "."}
    res = {"recording": "r.csv", "verdict": "missing physics found", "effects": [eff], "tentative": [],
           "unexplained": True, "residual": "M_d,1 - M_d,2", "nominal_rmse": 1.0, "augmented_rmse": 0.2,
           "noise_floor": 0.05, "heldout_over_floor": 4.0, "h_nominal": 1.2, "h_augmented": 0.6,
           "generic": {"gain": 0.3, "floor_ratio": 4.0}, "windows": [], "correlations": {},
           "notes": ["sensor_time_offset = 0.05 s lies on its search bound [-0.05, 0.05] s: it is a "
                     "bound, not an estimate"], "at_bound": ["h_nominal", "effects.sensor_time_offset"]}
    text = summary(res)
    assert "h = 1.200 m nominal (AT THE SEARCH BOUND), 0.600 m with the effects\n" in text
    assert "found: sensor_time_offset = 0.05 s (95% CI 0.04…0.06) (AT ITS SEARCH BOUND)" in text
    assert "note: sensor_time_offset = 0.05 s lies on its search bound" in text
    assert "(noise floor 0.050 N·m; held-out RMSE over the noise floor 4.0×)" in text
    assert "noise floor 4.0× with the accepted effects)" in text
    res = {**res, "tentative": [eff], "at_bound": []}
    text = summary(res)
    assert "noise floor 4.0× with every selected effect, the tentative ones too)" in text
    assert "AT" not in text.replace("UNEXPLAINED", "")


def test_refined_estimates_and_h_on_their_bounds_are_listed_once():
    from types import SimpleNamespace

    from euc_sim.diagnosis.common import H_BOUNDS

    fin = SimpleNamespace(fit=SimpleNamespace(h=H_BOUNDS[1]),
                          info={"rider_mass": {"at_bound": True, "search": (60.0, 85.0)},
                                "road_slope": {}})
    decision = {"effects": [{"name": "road_slope", "estimate": 0.02, "unit": "rad"}],
                "tentative": [{"name": "rider_mass", "estimate": 85.0, "unit": "kg"}]}
    hits = dict(diagnosis._at_bound(0.6, H_BOUNDS[1] - 0.001, fin, decision))
    assert list(hits) == ["h_augmented", "tentative.rider_mass"]
    assert hits["h_augmented"] == ""                     # the verdict's note already says it
    assert "rider_mass = 85 kg lies on its search bound [60, 85] kg" in hits["tentative.rider_mass"]
    fin.fit.h = 0.6                                      # the reported h alone on the bound: said here
    assert "lies on the search bound" in dict(diagnosis._at_bound(0.6, H_BOUNDS[1], fin, decision))["h_augmented"]
    assert list(dict(diagnosis._at_bound(H_BOUNDS[0], 0.6, fin, {"effects": [], "tentative": []}))) == ["h_nominal"]


def test_hot_windows_are_the_runs_lasting_min_len_including_one_at_either_end():
    from euc_sim.diagnosis.localise import hot_windows

    t = np.arange(12) * 0.25
    hot = np.array([1, 1, 1, 0, 1, 1, 0, 0, 1, 1, 1, 1], bool)
    assert hot_windows(t, hot, 0.5) == [[0.0, 0.5], [2.0, 2.75]]
    assert hot_windows(t, hot, 0.25) == [[0.0, 0.5], [1.0, 1.25], [2.0, 2.75]]
    assert hot_windows(t, np.zeros(12, bool), 0.0) == [] and hot_windows(t[:0], hot[:0], 0.0) == []
