"""The voltage-limited motor: torque falls with speed and battery voltage; past the
envelope the rider falls (with its time), inside it he rides on."""

from __future__ import annotations

import math

import numpy as np
import pytest

from euc_sim.controllers.motor import MotorError, MotorPD
from euc_sim.simulation.engine import simulate
from euc_sim.simulation.errors import FallError
from euc_sim.simulation.maneuvers import load_speed_profile

# a V9-like drivetrain (euc-sim ride on inmotion/v9/0): K_v 4.46 V per m/s, 0.047 V/N at R = 0.2 m
LIMIT = {"voltage": 84.0, "back_emf": 4.46, "drop": 0.047 / 0.2}


def test_voltage_torque_falls_with_speed_and_charge():
    m, low = MotorPD(**LIMIT), MotorPD(**{**LIMIT, "voltage": 66.0})
    speeds = np.linspace(0.0, 20.0, 41)
    full = np.array([m.voltage_torque(v) for v in speeds])
    assert np.all(np.diff(full[full > 0]) < 0)
    assert all(low.voltage_torque(v) < m.voltage_torque(v) or m.voltage_torque(v) == 0 for v in speeds)
    assert m.voltage_torque(84.0 / 4.46 + 0.1) == 0.0
    assert MotorPD().voltage_torque(30.0) == math.inf


def test_voltage_limit_clips_motoring_only():
    m = MotorPD(**LIMIT)
    v = 15.0
    M_v = (84.0 - 4.46 * v) / LIMIT["drop"]
    assert m.torque(1.0, 0.0, v) == pytest.approx(M_v)          # asks 600 N·m forward
    assert m.torque(-1.0, 0.0, v) == -250.0                     # braking: torque limit only
    assert m.torque(0.01, 0.0, v) == pytest.approx(6.0)         # small demand untouched
    assert m.as_dict()["voltage"] == 84.0 and MotorPD().as_dict()["voltage"] is None


def test_voltage_limit_rejects_bad_settings():
    with pytest.raises(MotorError, match="voltage limit needs voltage > 0 and drop > 0"):
        MotorPD(voltage=84.0, back_emf=4.0, drop=0.0)


@pytest.mark.parametrize("ride", [{"envelope": [1, 2]}, {"envelope": {"full": 84.0}},
                                  {"ocv_start": 84.0}])   # a number where {"estimate": V} belongs
def test_malformed_voltage_fields_named_not_a_traceback(ride):
    from euc_sim.controllers.firmware import FirmwareError, voltage_limit_settings

    dtr = {"back_emf_per_speed": {"estimate": 4.46}, "resistive_drop": {"estimate": 0.047}}
    rep = {"drivetrain": {**dtr, **{k: v for k, v in ride.items() if k == "ocv_start"}},
           **{k: v for k, v in ride.items() if k != "ocv_start"}}
    with pytest.raises(FirmwareError, match="no battery voltage"):
        voltage_limit_settings(rep, 0.2)
    assert voltage_limit_settings(rep, 0.2, voltage=84.0)["voltage"] == 84.0


def test_non_finite_voltage_or_drop_refused():
    from euc_sim.controllers.firmware import FirmwareError, voltage_limit_settings

    dtr = {"back_emf_per_speed": {"estimate": 4.46}, "resistive_drop": {"estimate": 0.047}}
    with pytest.raises(FirmwareError, match="finite positive number of volts"):
        voltage_limit_settings({"drivetrain": dtr, "envelope": {"full": {"voltage": math.inf}}}, 0.2)
    with pytest.raises(FirmwareError, match="resistive_drop"):
        voltage_limit_settings({"drivetrain": {**dtr, "resistive_drop": {"estimate": math.inf}}}, 0.2, 84.0)


def _profile(tmp_path, name, slope, top):
    t = np.linspace(0.0, 8.0, 81)
    p = tmp_path / name
    p.write_text("t,v\n" + "".join(f"{a:.2f},{min(4.0 + slope * a, top):.3f}\n" for a in t))
    return load_speed_profile(p)


def test_rider_past_the_envelope_falls_inside_rides_on(tmp_path):
    """On MuJoCo (the default engine, compiled loop); the fall on the analytic engine too, at the
    same time (the analytic engine's 1 ms solver steps take a minute for the three rides)."""
    motor = MotorPD(**{**LIMIT, "voltage": 60.0})          # low charge: no-load 13.5 m/s
    inside = simulate(_profile(tmp_path, "in.csv", 0.5, 8.0), 8.0, motor=motor)
    assert inside["x_dot"].iloc[-1] == pytest.approx(8.0, abs=1.0)
    falls = {}
    for engine in ("mujoco", "analytic"):
        with pytest.raises(FallError) as err:
            simulate(_profile(tmp_path, "out.csv", 1.5, 20.0), 8.0, motor=motor, engine=engine)
        falls[engine] = err.value.t
    # the motor runs out of voltage near 13 m/s, reached about 6 s in; the fall follows
    assert 4.0 < falls["mujoco"] < 8.0
    assert falls["analytic"] == pytest.approx(falls["mujoco"], abs=0.05)
    # without the limit the same demand is ridden
    free = simulate(_profile(tmp_path, "out2.csv", 1.5, 20.0), 8.0)
    assert free["x_dot"].iloc[-1] > 14.0
