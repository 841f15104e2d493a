"""The measured balance law in the simulator (issue 21, item 2): ``controllers.firmware``."""

from __future__ import annotations

import json

import pytest

from euc_sim.controllers.firmware import FirmwareError, firmware_motor, law_terms
from euc_sim.model.parameters import TABLE3
from euc_sim.simulation.engine import default_rider, simulate
from euc_sim.simulation.maneuvers import make_maneuver

#: A ``controller`` entry as ``euc-sim ride`` wrote it for Lynx ride 0 (--wheel lynx.csv).
LYNX = {"law": "PD on the pitch", "sign": -1,
        "terms": [{"name": "K_p", "estimate": 5365.2, "ci95": [5301.5, 5420.8], "unit": "N·m/rad"},
                  {"name": "K_d", "estimate": 29.37, "ci95": [5.09, 49.83], "unit": "N·m·s/rad"},
                  {"name": "pitch_zero", "estimate": -0.0348, "ci95": None, "unit": "rad (logged)"},
                  {"name": "accel_setpoint_gain", "estimate": -2.98e-4, "ci95": None,
                   "unit": "rad/(m/s^2)"}],
        "heldout": {"r2": 0.982, "channel": "phase_current"}}


def test_measured_law_rides_in_closed_loop():
    motor, notes = firmware_motor(law_terms(LYNX))
    assert motor.Kp == pytest.approx(5365.2) and motor.Kd == pytest.approx(29.37)
    assert any("accel_setpoint_gain" in n for n in notes)      # said, not silently dropped
    df = simulate(make_maneuver("stop_and_go"), 20.0, motor=motor, rider=default_rider(TABLE3, motor))
    assert df["x_dot"].max() > 2.0                              # rode the maneuver, no fall
    assert abs(df["gamma"]).max() < 0.05                        # a stiff law keeps the body near level


def test_tiltback_and_limit_carried():
    ctrl = dict(LYNX, terms=LYNX["terms"] + [
        {"name": "tiltback_speed", "estimate": 8.3, "unit": "m/s"},
        {"name": "tiltback_gain", "estimate": 0.0126, "unit": "rad/(m/s)"},
        {"name": "torque_limit", "estimate": 110.0, "unit": "N·m"}])
    motor, _ = firmware_motor(law_terms(ctrl))
    assert motor.tiltback_speed == 8.3 and motor.torque_limit == 110.0
    assert motor.gamma_ref(10.0) == pytest.approx(-0.0126 * 1.7)


@pytest.mark.parametrize("largest, used", [(137.0, 137.0), (100.0, 110.0), (None, 110.0)])
def test_limit_below_the_logs_largest_torque_is_raised(largest, used):
    """A fitted limit under the largest |torque| the log measured is raised to it, and said."""
    limit = {"name": "torque_limit", "estimate": 110.0, "ci95": [97.0, 121.0], "unit": "N·m"}
    if largest is not None:
        limit["largest_measured"] = largest
    motor, notes = firmware_motor(law_terms(dict(LYNX, terms=LYNX["terms"] + [limit])))
    assert motor.torque_limit == used
    assert any("largest |torque|" in n and "137" in n for n in notes) == (used == 137.0)


@pytest.mark.parametrize("ctrl, words", [
    ({"law": None, "why": "no pitch"}, "no pitch"),
    (dict(LYNX, terms=[{"name": "K_p", "estimate": 2800.0, "unit": "A/rad"}]), "N·m/rad"),
    (dict(LYNX, terms=[{"name": "K_p", "estimate": float("nan"), "unit": "N·m/rad"}]), "finite"),
    ("law", "expected an object"),
])
def test_bad_entries_named(ctrl, words):
    with pytest.raises(FirmwareError, match=words):
        firmware_motor(law_terms(ctrl))


def test_simulate_uses_the_measured_law(tmp_path, capsys):
    from euc_sim.cli.app import main

    ride = {"drivetrain": {"back_emf_per_speed": {"estimate": 7.5}, "resistive_drop": {"estimate": 0.01},
                           "ocv_start": {"estimate": 150.0}},
            "controller": LYNX}
    (tmp_path / "ride.json").write_text(json.dumps(ride))
    rc = main(["simulate", "--maneuver", "acceleration", "--duration", "8", "--drivetrain",
               str(tmp_path / "ride.json"), "--out", str(tmp_path / "sim.csv")])
    assert rc == 0
    meta = json.loads((tmp_path / "sim.truth.json").read_text())     # the test reads the truth
    assert meta["motor"]["Kp"] == pytest.approx(5365.2) and meta["motor"]["voltage"] == 150.0


def test_damping_floor_is_the_smallest_kd_reaching_the_stated_ratio():
    from euc_sim.controllers.damping import ZETA_UNRESOLVED, damping_floor, pitch_mode_damping

    kd = damping_floor(TABLE3, 5687.0)
    zeta, omega = pitch_mode_damping(TABLE3, 5687.0, kd)
    assert zeta == pytest.approx(ZETA_UNRESOLVED, abs=1e-4) and 50.0 < omega < 150.0   # the ~15 Hz pitch mode
    assert pitch_mode_damping(TABLE3, 5687.0, 0.95 * kd)[0] < ZETA_UNRESOLVED           # smallest such K_d
    assert pitch_mode_damping(TABLE3, 5687.0, 0.0)[0] < 0.05                            # undamped without it
    assert damping_floor(TABLE3, 5687.0, 0.3) < kd
    with pytest.raises(ValueError, match="zeta"):
        damping_floor(TABLE3, 5687.0, 1.5)


@pytest.mark.parametrize("ci95", [[-51.1, -29.2], [-12.3, 64.9], None])
def test_unresolved_kd_is_damped_and_said(ci95):
    from euc_sim.controllers.damping import damping_floor

    est = -37.0 if ci95 is None or ci95[1] < 0 else 24.2
    terms = [dict(t, estimate=est, ci95=ci95) if t["name"] == "K_d" else t for t in LYNX["terms"]]
    motor, notes = firmware_motor(law_terms(dict(LYNX, terms=terms)), TABLE3)
    assert motor.Kd == pytest.approx(damping_floor(TABLE3, 5365.2), rel=1e-6)
    assert any("not resolved" in n and f"{est:.3g}" in n and "damping ratio 0.7" in n for n in notes)


def test_resolved_kd_is_kept():
    motor, notes = firmware_motor(law_terms(LYNX), TABLE3)             # K_d 29.4, interval [5.1, 49.8] above 0
    assert motor.Kd == pytest.approx(29.37) and not any("not resolved" in n for n in notes)


def test_damped_law_does_not_chatter_where_kd_zero_does():
    """The Lynx 0 defect: K_p 5,687 with K_d taken as 0 left the pitch mode undamped."""
    import numpy as np

    from euc_sim.controllers.damping import damping_floor
    from euc_sim.controllers.motor import MotorPD

    rms = {}
    for kd in (0.0, damping_floor(TABLE3, 5687.0)):
        m = MotorPD(Kp=5687.0, Kd=kd)
        df = simulate(make_maneuver("stop_and_go"), 10.0, motor=m, rider=default_rider(TABLE3, m))
        rms[kd] = float(np.sqrt(np.mean(df["gamma_dot"] ** 2)))
    undamped, damped = rms.values()
    assert undamped > 1.0 and damped < 0.1
