"""The calibrated rider's settings and the rider they make (euc_sim.rides.rider.rider_params)."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.rides.grids.rider_features import RiderFitError
from euc_sim.rides.rider import rider_params as rp


def test_param_unit_coordinates_round_trip():
    for p in rp.RIDER_PARAMS:
        assert p.lo < p.nominal < p.hi
        for u in (0.0, 0.3, 1.0):
            assert p.to_unit(p.from_unit(u)) == pytest.approx(u, abs=1e-12)
        assert p.from_unit(0.0) == pytest.approx(p.lo) and p.from_unit(1.0) == pytest.approx(p.hi)


def test_bandwidth_stiffens_the_rider():
    from euc_sim.controllers.motor import MotorPD
    from euc_sim.model.parameters import TABLE3

    soft = rp.rider_from({"delay": 0.2, "bandwidth": 0.25, "noise_std": 4.0}, TABLE3, MotorPD())
    stiff = rp.rider_from({"delay": 0.2, "bandwidth": 4.0, "noise_std": 4.0}, TABLE3, MotorPD())
    assert soft.delay == pytest.approx(0.2) and soft.noise_std == pytest.approx(4.0)
    assert np.linalg.norm(stiff.K) > 1.5 * np.linalg.norm(soft.K)
    with pytest.raises(RiderFitError, match="bandwidth"):
        rp.rider_from({"delay": 0.2, "bandwidth": -1.0, "noise_std": 4.0}, TABLE3, MotorPD())
