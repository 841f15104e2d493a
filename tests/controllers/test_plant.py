"""The linear plant the rider balances: the right-half-plane zero of his speed response."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.plant import linear_plant, speed_zero
from euc_sim.model.parameters import TABLE3


def _speed_gain(p, motor, s: float) -> float:
    """|G(s)| of M_h -> ẋ, C (sI − A)⁻¹ B, m/s per N·m."""
    A, B = linear_plant(p, motor)
    return float(abs(np.linalg.solve(s * np.eye(A.shape[0]) - A, B)[0, 0]))


@pytest.mark.parametrize("motor", [MotorPD(), MotorPD(Kp=2803.0, Kd=57.9)])
def test_speed_zero_is_a_right_half_plane_zero_of_the_speed_response(motor):
    z = speed_zero(TABLE3, motor)
    assert z > 1.0, f"z = {z} rad/s: must be a real, positive zero"
    assert z < 10.0, f"z = {z} rad/s: about 3 rad/s expected for Table 3"
    # the transfer function vanishes there, and not a little way off it
    assert _speed_gain(TABLE3, motor, z) < 1e-6 * _speed_gain(TABLE3, motor, 1.3 * z)
    assert _speed_gain(TABLE3, motor, 0.7 * z) > 1e-3 * _speed_gain(TABLE3, motor, 1.3 * z)


def test_speed_zero_is_the_riders_not_the_motors():
    """The zero comes from the rider's pendulum (to speed up, the wheel first runs back under
    him): a stiffer balance law barely moves it, a higher centre of mass slows it."""
    z = speed_zero(TABLE3)
    assert speed_zero(TABLE3, MotorPD(Kp=5700.0, Kd=88.0)) == pytest.approx(z, rel=0.05)
    assert speed_zero(TABLE3.replace(h=0.8)) < z < speed_zero(TABLE3.replace(h=0.5))
