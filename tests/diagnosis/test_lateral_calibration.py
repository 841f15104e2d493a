"""The lateral term calibrated on a simulated twin: each choice divided by its gain on the
twin, the plan the twin rides, and the floor of the ``unexplained`` test."""

import math

import pytest

from euc_sim.diagnosis.lateral_calibration import calibrate_item, model_floor, plan_of
from euc_sim.diagnosis.prepare import prepare
from euc_sim.model.parameters import TABLE3
from tests.diagnosis.test_lateral_estimate import _circling


def _item(s, lo, hi, alternatives):
    a = list(alternatives.values())
    return {"name": "lateral_dynamics", "estimate": a[0] * math.sqrt(s),
            "ci95": [min(a) * math.sqrt(lo), max(a) * math.sqrt(hi)],
            "coupling": {"s": s, "s_ci95": [lo, hi], "alternatives": dict(alternatives)}}


def test_a_twin_reading_every_choice_10_percent_low_lifts_the_estimate_and_interval_by_1_over_0_9():
    alts = {"column, angle channel": 0.10, "window 0.25 s, angle channel": 0.095, "slender rider, angle channel": 0.105}
    rec = _item(0.81, 0.72, 0.90, alts)
    truth = 0.08
    twin = _item(0.64, 0.6, 0.7, {k: 0.9 * truth / math.sqrt(0.64) for k in alts})   # each reads 0.9 × truth
    out = calibrate_item(rec, twin, truth)
    est = rec["estimate"] / 0.9
    assert out["estimate"] == pytest.approx(est)
    # the choices' reach (−5 %, +5 %) and the coupling's (√(0.72/0.81), √(0.90/0.81)) in quadrature
    assert out["ci95"] == pytest.approx([est * (1 - math.hypot(0.05, 1 - math.sqrt(0.72 / 0.81))),
                                         est * (1 + math.hypot(0.05, math.sqrt(0.90 / 0.81) - 1))])
    cal = out["calibration"]
    assert cal["uncalibrated_estimate"] == rec["estimate"] and cal["uncalibrated_ci95"] == rec["ci95"]
    assert all(g == pytest.approx(0.9) for g in cal["gain"].values())


def test_choices_whose_spread_the_twin_shows_too_collapse_onto_the_column():
    alts = {"a": 0.10, "b": 0.12, "c": 0.09}
    rec = _item(0.81, 0.72, 0.90, alts)
    truth = 0.05
    twin = _item(1.0, 0.9, 1.1, {k: 0.5 * a for k, a in alts.items()})      # the same spread, column reads truth
    out = calibrate_item(rec, twin, truth)
    assert out["estimate"] == pytest.approx(0.10 * 0.9)
    assert out["ci95"] == pytest.approx([0.10 * math.sqrt(0.72), 0.10 * math.sqrt(0.90)])


def test_choices_the_twin_reads_alike_keep_their_reach_and_a_dead_twin_calibrates_nothing():
    rec = _item(1.0, 0.9, 1.1, {"a": 0.10, "b": 0.12})
    twin = _item(1.0, 0.9, 1.1, {"a": 0.05, "b": 0.05})        # both choices read its truth
    out = calibrate_item(rec, twin, 0.05)
    assert out["estimate"] == pytest.approx(0.10)
    assert out["ci95"] == pytest.approx([0.10 * math.sqrt(0.9), 0.10 * (1 + math.hypot(0.2, math.sqrt(1.1) - 1))])
    assert calibrate_item(rec, _item(0.0, 0.0, 0.1, {"a": 0.05}), 0.05) is None
    assert calibrate_item(rec, _item(1.0, 0.9, 1.1, {"c": 0.05}), 0.05) is None     # no common choice


def test_the_unexplained_floor_adds_the_twins_remainder_in_quadrature():
    assert model_floor(0.03, 0.04) == pytest.approx(0.05)
    assert model_floor(1e-4, 0.0) == pytest.approx(1e-4)


def test_the_plan_is_the_sidecars_or_read_from_the_recording():
    df, _ = _circling()          # 2 m/s on a circle of 4 m (the wheel centre's)
    given = plan_of(prepare(df, params=TABLE3, meta={"name": "c", "maneuver": "circle",
                                                      "maneuver_options": {"speed": 2.1, "radius": 3.9}}))
    assert given == {"path": "circle", "speed": 2.1, "radius": 3.9, "from": "sidecar"}
    read = plan_of(prepare(df, params=TABLE3, meta={"name": "c", "maneuver": "circle"}))
    assert read["from"] == "recording" and read["speed"] == pytest.approx(2.0, rel=0.1)
    assert read["radius"] == pytest.approx(4.0, rel=0.05)
    assert plan_of(prepare(df, params=TABLE3, meta={"name": "c", "maneuver": "deceleration"})) is None
    assert plan_of(prepare(df.drop(columns=["E_X", "E_Y", "E_Z"]), params=TABLE3,
                           meta={"name": "c", "maneuver": "slalom"})) is None


def test_what_the_twin_names_beside_the_lateral_term_is_not_named_on_the_recording():
    from euc_sim.diagnosis.lateral_calibration import twin_artifacts
    lat, mass, drag = ({"name": n, "estimate": v} for n, v in
                       (("lateral_dynamics", 0.1), ("rider_mass", 67.9), ("aerodynamic_drag", 0.4)))
    decision = {"effects": [lat, mass, drag], "tentative": [], "notes": []}
    assert twin_artifacts(decision, {"names": {"rider_mass": 68.3, "road_slope": -3e-4}}) == ["rider_mass"]
    assert decision["effects"] == [lat, drag] and decision["tentative"] == [mass]
    assert "rider_mass (twin 68.3)" in decision["notes"][0]
    assert twin_artifacts(decision, {"names": {"lateral_dynamics": 0.1}}) == []


def test_a_noise_free_circle_is_calibrated_onto_its_truth_by_its_twin(tmp_path):
    """An 8 s circle without motor or sensor noise: its twin rides the same plan, so the
    calibration must take the recording's loss (measured −2.2 % uncalibrated) off the estimate."""
    import json
    import warnings

    from euc_sim.diagnosis.pipeline import diagnose
    from euc_sim.simulation.spatial import write_spatial

    path = write_spatial(tmp_path / "c.csv", "circle", 8.0, seed=1, noise="none", rider_noise=0.0,
                         speed=2.0, radius=4.0)
    truth = json.loads((tmp_path / "c.truth.json").read_text())["peak_tilt_rad"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnose(path, resimulate=False)
    lc = res["lateral_calibration"]
    assert lc["done"] and lc["plan"] == {"path": "circle", "speed": 2.0, "radius": 4.0, "from": "sidecar"}
    item = next(e for e in res["effects"] if e["name"] == "lateral_dynamics")
    assert item["calibration"]["uncalibrated_estimate"] < 0.99 * truth           # the recording's loss
    assert item["estimate"] == pytest.approx(truth, rel=0.005)
    assert item["ci95"][0] <= truth <= item["ci95"][1]
    assert not res["unexplained"] and lc["unexplained_floor"] > res["noise_floor"]
