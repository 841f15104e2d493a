"""The damping the simulator gives a measured balance law whose K_d the log cannot resolve.

A 5–10 Hz log sees the body pitch mode (near 15 Hz) only aliased, so its K_d can come out
at or below zero; the simulator then uses the smallest K_d giving the pitch mode the
damping ratio ζ at the measured K_p (:func:`damping_floor`).  The pitch mode is the
fastest oscillatory eigenvalue λ of :func:`euc_sim.controllers.plant.linear_plant` (the
ankle torque held at zero), ζ = −Re λ / |λ| (1 where none oscillates).
"""

from __future__ import annotations

import numpy as np
import scipy.optimize

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.plant import linear_plant
from euc_sim.errors import InputError
from euc_sim.model.parameters import Params

__all__ = ["ZETA_UNRESOLVED", "pitch_mode_damping", "damping_floor"]

#: Damping ratio the simulator gives the pitch mode when the log cannot resolve K_d
#: (the conventional well-damped design value).
ZETA_UNRESOLVED = 0.7


def pitch_mode_damping(p: Params, Kp: float, Kd: float) -> tuple[float, float]:
    """(ζ, ω): damping ratio and |λ| (rad/s; nan when none oscillates) of the body pitch mode
    under the law (K_p, N·m/rad; K_d, N·m·s/rad).
    """
    A, _ = linear_plant(p, MotorPD(Kp=Kp, Kd=Kd))
    lam = np.linalg.eigvals(A)
    osc = lam[np.abs(lam.imag) > 1e-9 * np.maximum(1.0, np.abs(lam))]
    if osc.size == 0:
        return 1.0, float("nan")
    fast = osc[np.argmax(np.abs(osc))]
    return float(-fast.real / abs(fast)), float(abs(fast))


def damping_floor(p: Params, Kp: float, zeta: float = ZETA_UNRESOLVED) -> float:
    """The smallest K_d ≥ 0, N·m·s/rad, giving the pitch mode the damping ratio ``zeta`` ∈ (0, 1)
    at ``Kp`` > 0, N·m/rad (bracketing, then Brent); ``InputError`` for bad arguments or none
    below 1e6.
    """
    if not Kp > 0:
        raise InputError(f"Kp must be positive, got {Kp!r}")
    if not 0.0 < zeta < 1.0:
        raise InputError(f"zeta must be in (0, 1), got {zeta!r}")

    def gap(Kd: float) -> float:
        return pitch_mode_damping(p, Kp, Kd)[0] - zeta

    if gap(0.0) >= 0:
        return 0.0
    hi = 1.0
    while gap(hi) < 0:
        hi *= 2.0
        if hi > 1e6:
            raise InputError(f"no K_d below 1e6 N·m·s/rad gives damping ratio {zeta} at K_p = {Kp}")
    return float(scipy.optimize.brentq(gap, 0.0, hi, xtol=1e-6 * hi))
