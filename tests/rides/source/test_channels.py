"""Channels the app derives rather than the wheel measures."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from euc_sim.rides.source.channels import current_from_phase, duty_from_speed, power_not_measured
from euc_sim.rides.source.logs import Ride


def _log(measured_duty: bool, seed: int = 0) -> Ride:
    rng = np.random.default_rng(seed)
    n = 2000
    v = 8.0 + 4.0 * np.sin(np.arange(n) / 50.0)                  # m/s
    I_ph = np.abs(20.0 + 15.0 * rng.standard_normal(n))           # A
    V = 84.0 - 0.05 * I_ph
    duty = (6.0 * v + (0.15 * I_ph if measured_duty else 0.0)) / V   # back-EMF (+ drop R·I_ph)
    data = pd.DataFrame({"t": np.arange(n) * 0.2, "v": v, "voltage": V, "phase_current": I_ph,
                         "pwm": 100.0 * duty, "current": duty * I_ph})
    fields = {f.name: None for f in dataclasses.fields(Ride) if f.init}
    fields.update(path="synthetic.csv", layout="wheellog", variant="new", data=data,
                  start=pd.Timestamp(0), absent=(), warnings=(), n_rows_read=n)
    if "n_rows_merged" in fields:
        fields["n_rows_merged"] = 0
    return Ride(**fields)


def test_duty_computed_from_speed_is_found_and_its_constant_named():
    log = _log(measured_duty=False)
    assert duty_from_speed(log) == pytest.approx(6.0, rel=1e-9)
    assert current_from_phase(log)
    msg = power_not_measured(log)
    assert msg.startswith("V·I is not battery power") and "6.000 V per m/s" in msg


def test_measured_duty_is_not_taken_for_a_derived_one():
    log = _log(measured_duty=True)
    assert duty_from_speed(log) is None
    assert power_not_measured(log) == ""
