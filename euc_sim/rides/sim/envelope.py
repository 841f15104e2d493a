"""What the simulated rider can ride: the acceleration envelope of a logged speed profile.

:func:`rider_acceleration_limit` is the acceleration at which the rider's steady lean uses
:data:`LEAN_SHARE` of the fall bound, less what rolling resistance and slope take
(:func:`resisting_acceleration`); :func:`limit_acceleration` smooths a profile to a given
acceleration; :func:`moving_average` and :func:`plan_band_limit` give the band a rider's
plan can follow.  :mod:`euc_sim.rides.sim.tracking` rides the profile so shaped.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.plant import speed_zero
from euc_sim.controllers.rider import trim
from euc_sim.errors import InputError
from euc_sim.model.parameters import Params
from euc_sim.simulation.engine import FALL_BOUNDS

__all__ = ["LEAN_SHARE", "limit_acceleration", "moving_average", "plan_band_limit",
           "rider_acceleration_limit", "resisting_acceleration"]

#: Share of the fall bound |φ| ≤ φ_max the rider's steady lean φ*(a) may use (1.5 m/s² for
#: Table 3; the rest is the lean's overshoot).  Value: docs/ride_falls.md#the-fix.
LEAN_SHARE = 0.3


def limit_acceleration(t: np.ndarray, v: np.ndarray, a_max: float) -> np.ndarray:
    """A speed profile ``v`` (m/s, at ``t`` s) whose slope never exceeds ±``a_max`` m/s².

    The mean of a rate limiter run forwards and one run backwards: each keeps the bound,
    and the lag of one cancels the lead of the other (no net time shift).
    """
    if not (math.isfinite(a_max) and a_max > 0):
        raise InputError(f"a_max must be a positive number of m/s², got {a_max!r}")
    t = np.asarray(t, float)
    v = np.asarray(v, float)
    dv = a_max * np.diff(t)

    def one_way(x: np.ndarray, steps: np.ndarray) -> np.ndarray:
        out = x.copy()
        for i in range(1, out.size):
            out[i] = min(max(out[i], out[i - 1] - steps[i - 1]), out[i - 1] + steps[i - 1])
        return out

    fwd = one_way(v, dv)
    bwd = one_way(v[::-1], dv[::-1])[::-1]
    return 0.5 * (fwd + bwd)


def moving_average(t: np.ndarray, v: np.ndarray, width: float) -> np.ndarray:
    """Centred moving average of a uniformly sampled profile over ``width`` s (no time shift).

    The window is the odd number of samples nearest ``width``, the ends padded with their
    values; a slope within ±a stays within it.  The gain falls to 1/√2 at ω = 2.783/width rad/s.
    """
    t = np.asarray(t, float)
    v = np.asarray(v, float)
    if not (math.isfinite(width) and width >= 0):
        raise InputError(f"moving-average width must be a non-negative number of s, got {width!r}")
    if v.size < 2:
        return v.copy()
    n = int(round(width / float(np.median(np.diff(t)))))
    n = n + 1 if n % 2 == 0 else n
    if n <= 1:
        return v.copy()
    from scipy.ndimage import uniform_filter1d

    return uniform_filter1d(v, n, mode="nearest")      # centred (n odd); ends padded with their values


#: Gain 1/√2 of a centred moving average at ω·width = 2·1.3916 (sin x / x = 1/√2 at x = 1.3916).
_BOX_HALF_POWER = 2.0 * 1.3916


def plan_band_limit(params: Params, motor=None) -> tuple[float, float]:
    """(width s, z rad/s): the moving average band-limiting the rider's plan to ω_B = z/2.

    z is the right-half-plane zero of the wheel speed's response to the ankle torque
    (:func:`~euc_sim.controllers.plant.speed_zero`), which bounds any speed tracking to
    ω_B < z/2 (Skogestad and Postlethwaite, 2005, §5.6); the width puts the average's
    half-power gain there.  Width 0 without such a zero.
    """
    z = speed_zero(params, motor)
    if not (math.isfinite(z) and z > 0):
        return 0.0, z
    return _BOX_HALF_POWER / (0.5 * z), z


def rider_acceleration_limit(params: Params, motor=None, lean_share: float = LEAN_SHARE) -> float:
    """The largest |a|, m/s², whose steady lean |φ*(a)| (:func:`~euc_sim.controllers.rider.trim`)
    stays within ``lean_share`` × the fall bound φ_max (rad), braking and accelerating alike.
    """
    from scipy.optimize import brentq

    if not (math.isfinite(lean_share) and 0 < lean_share < 1):
        raise InputError(f"lean_share must be in (0, 1), got {lean_share!r}")
    motor = motor or MotorPD()
    target = lean_share * FALL_BOUNDS["phi"]

    def excess(a: float) -> float:
        return abs(float(trim(params, motor, a)[1])) - target

    return min(brentq(excess, 0.0, sign * params.g * 2, xtol=1e-4) * sign for sign in (1.0, -1.0))


def resisting_acceleration(params: Params, effects: Mapping[str, float]) -> float:
    """The speed-independent resistance the rider's lean must add, m/s²: C_rr·g·cos α + g·|sin α|
    from ``effects`` ``rolling_resistance`` and ``road_slope`` (rad); drag is not counted.
    """
    alpha = float(effects.get("road_slope", 0.0))
    return params.g * (float(effects.get("rolling_resistance", 0.0)) * math.cos(alpha) + abs(math.sin(alpha)))
