"""studies/rider_fit_falls.py: the fit's inputs read back from a ride page's JSON, and its bad-input exit."""

import json
import sys

import pytest

import rider_fit_falls


def _ride(measured_ran: bool) -> dict:
    law = {"K_p": 600.0, "K_d": 40.0, "torque_limit": 250.0}
    measured = {"K_p": 5000.0, "K_d": 90.0, "torque_limit": 250.0, "tiltback_speed": 14.0, "tiltback_gain": 0.001}
    step = lambda name, ran, motor, **kw: {"step": name, "ran": ran, "motor": motor, **kw}  # noqa: E731
    return {"assumptions": {"R": 0.254, "total_mass": 150.0, "m_eq": 157.0},
            "drivetrain": {"back_emf_constant": {"estimate": 2.1}},
            "simulation": {"steps": [
                step("nominal", True, law), step("measured_law", measured_ran, measured),
                step("calibrated_rider", False, measured if measured_ran else law),
                step("drivetrain", True, {**law, "voltage": 150.0},
                     effects_injected={"rolling_resistance": 0.02}, power_model={"copper_loss": 0.004,
                                                                                  "drivetrain_idle_loss": 30.0})]}}


@pytest.mark.parametrize("measured_ran, kp", [(True, 5000.0), (False, 600.0)])
def test_the_step_before_the_calibrated_rider_gives_the_motor(measured_ran, kp):
    got = rider_fit_falls.fit_inputs(_ride(measured_ran))
    assert got["motor"].Kp == kp and got["motor"].voltage == float("inf")   # not the drivetrain step's
    assert got["effects"] == {"rolling_resistance": 0.02} and got["drivetrain"]["drivetrain_idle_loss"] == 30.0
    assert got["params"].R == 0.254 and got["params"].m + got["params"].m0 + got["params"].mw == pytest.approx(150.0)
    assert got["assumptions"].torque_constant == 2.1


def test_a_page_without_the_calibrated_rider_is_refused_with_exit_2(tmp_path, capsys):
    ride = _ride(True)
    ride["simulation"]["steps"] = ride["simulation"]["steps"][:2]
    p = tmp_path / "ride.json"
    p.write_text(json.dumps(ride))
    assert rider_fit_falls.main([str(p), str(tmp_path / "fit.csv"), "--out", str(tmp_path / "o.json")]) == 2
    assert "calibrated_rider" in capsys.readouterr().err
