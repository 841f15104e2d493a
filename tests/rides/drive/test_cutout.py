"""The wheel's limits and its cut-out speed (euc_sim.rides.drive.cutout): the solved speed against
the closed form, the duty rising with speed, no sentence giving speed beyond the wheel's limit, the
held-out duty error on a twin, and the page's chart in a browser."""

from __future__ import annotations

import json
from dataclasses import replace
import math
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from euc_sim.report.ride.contract import limits_json
from euc_sim.rides.drive.drivetrain_report import DutyCheck
from euc_sim.rides.drive.cutout import (CONDITIONS, Curve, DutyModel, Limits, OcvLine,
                                        cutout_curves, danger_sentence, duty, envelope, full_duty_accel,
                                        headroom_words, limit_speed, ocv_line, ride_limits)

sys.path.append(str(Path(__file__).resolve().parents[1]))

LEVEL, ACCEL, CLIMB = CONDITIONS
FLAT = OcvLine(66.0, 0.18, "test")          # 66 V at 0 %, 84 V at 100 %


def _model(**kw) -> DutyModel:
    base = dict(pwm={"K_v": 5.5, "r_F": 0.02}, R_int=0.0, ocv=FLAT, m_eq=120.0, mass=115.0, c1=60.0,
                c3=0.0)
    return DutyModel(**{**base, **kw})


@pytest.mark.parametrize("cond", CONDITIONS, ids=lambda c: c.name)
@pytest.mark.parametrize("charge", [0.0, 40.0, 100.0])
def test_cutout_speed_is_the_closed_form(cond, charge):
    """No sag, no losses: K·v + r_F·(m_eq·a + m·g·sinθ + c₁ + c₃v²) = V, a quadratic in v."""
    m = _model(c3=0.3)
    V = 66.0 + 0.18 * charge
    F0 = m.m_eq * cond.accel + m.mass * 9.81 * math.sin(math.atan(cond.grade)) + m.c1
    a, b, c = m.pwm["r_F"] * m.c3, m.pwm["K_v"], m.pwm["r_F"] * F0 - V
    want = (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
    assert limit_speed(m, V, cond) == pytest.approx(want, rel=1e-5)


def test_with_sag_the_solved_speed_satisfies_the_battery_and_the_motor():
    """At the cut-out, the terminal voltage is all the motor's (K·v + r_F·P/v) and the battery gives P."""
    m = _model(R_int=0.25, c3=0.35, p0=40.0, copper=0.004, copper_column="force", scale=0.93,
               pwm={"K_v": 5.5, "r_F": 0.02, "dead_time": 0.02})
    v = limit_speed(m, FLAT(50.0), ACCEL)
    vg = 0.93 * v
    F = m.m_eq * 1.0 + m.c1 + m.c3 * vg ** 2
    P = F * vg + 40.0 + 0.004 * F ** 2
    E = 66.0 + 0.18 * 50.0
    Vt = (5.5 * v + 0.02 * P / v) / (1.0 - 0.02)
    assert Vt * (E - Vt) / 0.25 == pytest.approx(P, rel=1e-3)
    assert limit_speed(_model(c3=0.35, scale=0.93, pwm={"K_v": 5.5, "r_F": 0.02}), FLAT(50.0), ACCEL) > v


HAND = dict(pwm={"K_v": 5.0, "r_F": 0.02}, m_eq=100.0, mass=100.0, c1=50.0, c3=0.0, ocv=OcvLine(60.0, 0.2, "x"))


def test_duty_on_hand_computed_numbers():
    """10 m/s on the level, 80 V open-circuit, R_int 0.1 Ω: F = 50 N, P = 500 W;
    V_t·(80 − V_t) = 0.1·500 gives V_t = (80 + √6200)/2 = 79.3700; d = (5·10 + 0.02·50)/79.3700 = 0.642560.
    Climbing 10 % adds 100·9.81·sin(atan 0.1) = 97.613 N: P = 1476.13 W, V_t = (80 + √5809.55)/2 = 78.1102,
    d = (50 + 0.02·147.613)/78.1102 = 0.677917."""
    m = DutyModel(R_int=0.1, **HAND)
    assert float(duty(m, 10.0, 80.0)) == pytest.approx(0.642560, abs=2e-6)
    assert float(duty(m, 10.0, 80.0, grade=0.1)) == pytest.approx(0.677917, abs=2e-6)
    assert np.isnan(duty(m, 1.0, 80.0)) and np.isinf(duty(m, 10.0, 80.0, accel=1e3))   # unfitted; over the battery


def test_the_speed_at_a_given_duty_on_hand_computed_numbers():
    """No sag, F = 50 N: d = (5·v + 1)/80 reaches 50 % at v = 39/5 = 7.8 m/s and 100 % at 79/5 = 15.8 m/s."""
    m = DutyModel(R_int=0.0, **HAND)
    assert limit_speed(m, 80.0, LEVEL, fraction=0.5) == pytest.approx(7.8, abs=1e-4)
    assert limit_speed(m, 80.0, LEVEL) == pytest.approx(15.8, abs=1e-4)
    assert limit_speed(m, 80.0, LEVEL, fraction=0.01) == 0.0 and math.isnan(limit_speed(m, 1e4, LEVEL))


def test_the_acceleration_left_on_hand_computed_numbers():
    """At 10 m/s, 80 V: without sag 50 + 0.02·(100·a + 50) = 80 gives a = 14.5 m/s² (12.5 with a dead time of
    0.05: the volts left are 76); with R_int 0.1 Ω, V_t = 50 + 0.02·F and V_t·(80 − V_t) = 0.1·10·F give
    0.0004·F² + 1.4·F − 1500 = 0, F = 860.076 N, a = 8.10076 m/s².  None is left at 15.8 m/s and above."""
    v = np.array([10.0, 15.8, 20.0])
    a = full_duty_accel(DutyModel(R_int=0.0, **HAND), v, 80.0)
    assert a[0] == pytest.approx(14.5, abs=1e-9) and np.isnan(a[1:]).all()
    dead = DutyModel(R_int=0.0, **{**HAND, "pwm": {"K_v": 5.0, "r_F": 0.02, "dead_time": 0.05}})
    assert full_duty_accel(dead, np.array([10.0]), 80.0)[0] == pytest.approx(12.5, abs=1e-9)
    F = (-1.4 + math.sqrt(1.4 ** 2 + 4 * 0.0004 * 1500)) / (2 * 0.0004)
    assert full_duty_accel(DutyModel(R_int=0.1, **HAND), np.array([10.0]), 80.0)[0] == pytest.approx(
        (F - 50.0) / 100.0, abs=1e-9)


def test_the_envelope_ends_where_the_cutout_chart_does():
    """The envelope at full and empty charge: its steady PWM reaches 100 % and its acceleration runs out at
    the cut-out chart's level speed at 100 % and 0 % charge (one model, one speed)."""
    m = _model(R_int=0.2, c3=0.3, p0=40.0, copper=0.004, copper_column="force", scale=0.93,
               pwm={"K_v": 5.5, "r_F": 0.02, "dead_time": 0.02})
    cut = cutout_curves(m, Limits(None, None, None))
    env = envelope(m, 10.0, n=401)
    for side, k in ((env.full, -1), (env.low, 0)):
        assert side.v_limit == cut.curves[0].speed_mps[k] == limit_speed(m, side.voltage, LEVEL)
        v = np.interp(100.0, side.pwm_pct[5:], env.speed[5:])       # from 2 m/s up, the PWM rises
        assert v == pytest.approx(side.v_limit, abs=1e-3)
        left = np.isfinite(side.accel)
        assert env.speed[left].max() < side.v_limit < env.speed[~left & (env.speed > 2.0)].min()
    assert (env.full.voltage, env.low.voltage) == (pytest.approx(84.0), pytest.approx(66.0))


def test_duty_rises_with_speed_for_fitted_like_models():
    rng = np.random.default_rng(3)
    v = np.linspace(2.0, 25.0, 400)
    for _ in range(50):
        K, c = rng.uniform(2.5, 8.0), rng.uniform(0, 0.3)
        # the back-EMF rises up to the fastest speed fitted (v_fw), as a real fit's does
        pwm = {"K_v": K, "r_F": rng.uniform(0.0, 0.05), "dead_time": rng.uniform(0, 0.03),
               "flux_weakening": c, "v_fw": rng.uniform(8, 25) * min(1.0, 0.9 * K / (2 * c * 25))}
        m = _model(pwm=pwm, R_int=rng.uniform(0, 0.3), c1=rng.uniform(20, 90), c3=rng.uniform(0.1, 0.6),
                   p0=rng.uniform(0, 60), ocv=OcvLine(K * 12.0, K * 0.04, "x"))
        for cond in CONDITIONS:
            d = duty(m, v, float(m.ocv(rng.uniform(0, 100))), cond.accel, cond.grade)
            d = d[np.isfinite(d)]
            assert np.all(np.diff(d) > 0), (pwm, cond)


def test_curves_rise_with_charge_and_accelerating_is_lower():
    cut = cutout_curves(_model(R_int=0.2, c3=0.3), Limits(30 / 3.6, "log", None))
    level, accel, climb = (np.asarray(c.speed_mps) for c in cut.curves)
    assert np.all(np.diff(level) > 0) and np.all(accel < level) and np.all(climb < level)


def test_the_danger_names_the_charge_where_the_cutout_falls_under_the_limit():
    m = _model(R_int=0.2, c3=0.3)
    accel = np.array([limit_speed(m, FLAT(q), ACCEL) for q in (30.0, 31.0)])
    L = float(accel.mean())                       # the accelerating curve crosses it near 30.5 %
    cut = cutout_curves(m, Limits(L, "log", None), charge=np.linspace(0, 100, 101))
    assert re.match(r"Below 3[01] % charge, accelerating at 1 m/s²", cut.danger)
    assert "tilt-back speed" in cut.danger
    assert cutout_curves(m, Limits(0.5 * L, "log", None)).danger is None
    assert cutout_curves(m, Limits(None, None, None)).danger is None


KMH = re.compile(r"(\d+) km/h")


def _random_curves(rng):
    q = np.linspace(0, 100, 21)
    out = []
    for cond in CONDITIONS:
        s = rng.uniform(3, 20) + rng.uniform(0, 0.2) * q
        s[rng.random(q.size) < 0.05] = np.nan
        out.append(Curve(cond, q, s))
    return out


def test_no_sentence_gives_speed_beyond_the_limit(ride_result):
    """Property over random rides: every speed said (but the rider's own) is at most the limit."""

    from euc_sim.rides.drive.cutout import Cutout
    from euc_sim.report.ride.limits_page import limit_sentences

    rng = np.random.default_rng(11)
    for _ in range(400):
        L = rng.uniform(5, 25)
        lim = Limits(L, str(rng.choice(["log", "spec"])), None)
        curves = _random_curves(rng)
        danger = danger_sentence(curves, lim)
        rider = rng.uniform(1, 30)
        cut_then = None if rng.random() < 0.2 else rng.uniform(3, 60)
        words = headroom_words(rider * 3.6, lim, cut_then)
        m = re.search(r"(\d+) km/h under", words)
        if m:
            assert int(m[1]) <= round(L * 3.6 - rider * 3.6) + 1
        for text in [danger or "", words]:
            assert all(int(x) <= round(L * 3.6) for x in KMH.findall(text)), text
        r = ride_result.rider
        res = replace(ride_result, rider=replace(r, summary=replace(r.summary, limits=lim)),
                      cutout=Cutout(curves=tuple(curves), danger=danger))
        lead = " ".join(limit_sentences(res, None))
        assert "left" not in lead
        assert all(int(x) <= round(L * 3.6) for x in KMH.findall(lead)), lead


def test_limits_prefer_the_log_then_the_spec():
    assert limits_json(ride_limits(35 / 3.6, 45 / 3.6))["source"] == "log"
    s = ride_limits(None, 45 / 3.6)
    assert (s.source, round(s.speed_limit_mps * 3.6)) == ("spec", 45)
    none = limits_json(ride_limits(float("nan"), None))
    assert none["speed_limit_mps"] is None and none["source"] is None and "spec" in none["why"]


def test_ocv_line_from_the_log_or_from_the_cells():
    q = np.linspace(95, 40, 500)
    line = ocv_line(60.0 + 0.2 * q, np.zeros(q.size), q, 0.1)
    assert (line.alpha, line.beta) == (pytest.approx(60.0), pytest.approx(0.2))
    narrow = ocv_line(np.full(200, 82.2), None, np.full(200, 90.0), 0.1)      # 20 × 4.11 V
    assert narrow.source.startswith("20 cells") and narrow(100.0) == pytest.approx(84.0)
    assert ocv_line(np.full(50, 80.0), None, None, 0.1, spec_voltage=84.0)(0.0) == pytest.approx(66.0)
    assert ocv_line(np.full(50, 80.0), None, None, 0.1) is None


# ----------------------------------------------------------------------------------- the twin
@pytest.fixture(scope="module")
def twin(tmp_path_factory):
    """The EUC World twin (PWM from K_v·v + r_F·P/v) with a 30 km/h speed limit logged, through
    ``ride --no-simulate --report``."""
    from drivesynth import drive_log

    from euc_sim.cli import main

    d = tmp_path_factory.mktemp("cut")
    log = drive_log(d / "drive.csv", seed=4, duration=300.0)
    t = pd.read_csv(log, dtype=str, keep_default_na=False)
    t.insert(6, "speed_limit", "30.00")
    t["battery"] = [f"{x:.0f}" for x in np.linspace(95, 70, len(t))]
    t.to_csv(log, index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main([str(a) for a in ["ride", log, "--no-simulate", "--n-boot", "10", "--report", d / "rep",
                                      "--json", d / "r.json", "--quiet"]]) == 0
    return d / "rep" / "index.html", json.loads((d / "r.json").read_text())


def test_the_twin_json_carries_limits_and_cutout(twin):
    _, rep = twin
    assert rep["summary"]["limits"]["source"] == "log"
    assert rep["summary"]["limits"]["speed_limit_mps"] == pytest.approx(30 / 3.6)
    cut = rep["cutout"]
    assert [c["condition"] for c in cut["curves"]] == [c.name for c in CONDITIONS]
    assert cut["heldout_pwm_rmse_pct"] < 2.0            # the twin's duty has 1 point of noise
    # its K_v = 6 V/(m/s), 66–84 V: the back-EMF alone ends the duty near 40–50 km/h on the level
    level = np.array(cut["curves"][0]["speed_mps"], float) * 3.6
    assert 35 < level[0] < level[-1] < 55


def test_the_page_leads_with_the_limit_and_never_a_margin_beyond_it(twin):
    page, rep = twin
    import html

    lead = html.unescape(re.search(r'<p class="lead">(.*?)</p>', page.read_text()).group(1))
    assert "Your wheel's limit: 30 km/h (the tilt-back speed set in the wheel, from the log)" in lead
    assert "left" not in lead
    said = [int(x) for x in KMH.findall(re.sub(r"riding \d+ km/h", "", lead))]
    assert said and max(said) <= 30, lead


def test_the_cutout_chart_is_drawn_in_a_browser(twin):
    import browser

    browser.chromium_or_skip()
    page, _ = twin
    ready = ("document.querySelectorAll('.fig').length === "
             "document.querySelectorAll('.fig.js-plotly-plot').length")
    traces = "document.getElementById('cutout').data.length"
    axis = "document.getElementById('cutout').layout.yaxis.title.text"
    title = "document.getElementById('cutout').layout.title.text"
    r = browser.render(page, page.parent / "shot.png", (ready, traces, axis, title), ready=ready)
    assert r.script_errors() == []
    assert r.values[ready] is True
    assert r.values[traces] == 5                  # three conditions, the limit, the ride's points
    assert "km/h" in r.values[axis] and "cut-out" in r.values[title]


def test_the_envelope_says_the_cutout_charts_speeds_not_a_second_set(twin):
    """Blitz 4: the cut-out chart put the motor out of voltage on the level at 92 km/h at 100 %
    charge (the log's own charge to volts) while the envelope said "at full charge (134 V) none
    is left above 96 km/h" (the spec's voltage): one limit, two figures.  The envelope keeps its
    voltages and gives the chart's speeds; its curves on the page are named by voltage alone."""
    import browser

    page, rep = twin
    level = [c for c in rep["cutout"]["curves"] if c["condition"] == "level"][0]
    ends = [3.6 * level["speed_mps"][level["charge_pct"].index(q)] for q in (100.0, 0.0)]
    md = (page.parent / "index.md").read_text()
    line = next(x for x in md.splitlines() if x.startswith("Envelope (voltage limit)"))
    assert f": {ends[0]:.0f} km/h at 100 %, {ends[1]:.0f} km/h at 0 %." in line and "none is left above" not in line
    browser.chromium_or_skip()
    names = "document.getElementById('envelope').data.map(d => d.name).join('|')"
    r = browser.render(page, page.parent / "env.png", (names,), ready="!!document.getElementById('envelope').data")
    assert r.script_errors() == [] and "the pack at" in r.values[names] and "charge" not in r.values[names]


def test_the_envelope_and_the_cutout_chart_state_one_speed(twin):
    """The ride JSON's envelope at full charge runs out on the level at the cut-out chart's speed at 100 %
    charge, and at empty charge at its speed at 0 % (they were two models of the duty: the envelope's
    reached 100 % at 96 km/h on Blitz 4 where the chart said 92)."""
    _, rep = twin
    level = next(c for c in rep["cutout"]["curves"] if c["condition"] == "level")
    env = rep["envelope"]
    assert env["full"]["v_limit"] == pytest.approx(level["speed_mps"][-1], abs=1e-6)
    assert env["low"]["v_limit"] == pytest.approx(level["speed_mps"][0], abs=1e-6)


def test_an_apps_computed_pwm_is_not_called_a_check(tmp_path, ride_result):
    """Z10 and MTen4: the app computes the PWM from speed and voltage, so the duty model fits its formula
    and the page said "to 0.0 points RMS", a check of nothing.  Neither the JSON nor the page gives one."""
    from drivesynth import drive_log

    from euc_sim.cli import main
    from euc_sim.report.ride.limits_page import pwm_check

    log = drive_log(tmp_path / "app.csv", seed=4, duration=300.0)
    t = pd.read_csv(log, dtype=str, keep_default_na=False)
    v, V = t["speed"].astype(float) / 3.6, t["voltage"].astype(float)
    t["safety_margin"] = [f"{x:.1f}" for x in 100.0 - 100.0 * 6.0 * v / V]      # the app's duty, 6 V per m/s
    t.to_csv(log, index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["ride", str(log), "--no-simulate", "--n-boot", "20", "--report", str(tmp_path / "r"),
                     "--json", str(tmp_path / "r.json"), "--quiet"]) == 0
    rep = json.loads((tmp_path / "r.json").read_text())
    assert "app's computation" in rep["cutout"]["why"] and rep["cutout"]["heldout_pwm_rmse_pct"] is None
    md = (tmp_path / "r" / "index.md").read_text()
    assert "app's computation" in md and "points RMS" not in md
    m = ride_result.mass
    held = lambda rmse: DutyCheck("other.csv", np.zeros(3), np.zeros(3), rmse)  # noqa: E731
    computed = replace(m, duty_heldout=held(0.0), fit=replace(m.fit, pwm_note="the app computes it"))
    assert pwm_check(replace(ride_result, mass=computed,
                             cutout=replace(ride_result.cutout, heldout_pwm_rmse_pct=0.01))) is None
    assert pwm_check(replace(ride_result, mass=replace(m, duty_heldout=held(1.5), fit=replace(m.fit, pwm_note=None))))[2] == 1.5


def test_the_spec_gives_its_top_speed_and_an_unreadable_one_is_left_out(tmp_path):
    from euc_sim.report.ride.contract import spec_json
    from euc_sim.rides.source.spec import read_spec

    p = tmp_path / "w.csv"
    p.write_text("Field|Data\nNet weight| 23.5 kg\nMax speed| 122 km/h (150km/h Race mode)\n")
    assert read_spec(p).top_speed * 3.6 == pytest.approx(122.0)
    assert spec_json(read_spec(p))["top_speed_mps"] == pytest.approx(122 / 3.6)
    p.write_text("Field|Data\nNet weight| 23.5 kg\nMax speed| fast\n")
    assert read_spec(p).top_speed is None
