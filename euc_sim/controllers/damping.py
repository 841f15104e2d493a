"""The damping the simulator gives a measured balance law whose K_d the log cannot resolve.

A wheel's firmware runs M_d = K_p (γ − γ_ref) + K_d γ̇ at hundreds of hertz; a 5–10 Hz
log sees the body pitch mode (for K_p of a few thousand N·m/rad, near 15 Hz) only
aliased, and its K_d can come out at or below zero.  A real wheel is damped, and the
simulated wheel with K_d = 0 chatters.  Where the measured K_d's 95 % interval reaches
zero or below, the simulator uses the smallest K_d that gives the body pitch mode a
stated damping ratio ζ at the measured K_p (:func:`damping_floor`).

The pitch mode is the fastest oscillatory eigenvalue λ of the linearised plant with the
law closed (:func:`euc_sim.controllers.plant.linear_plant`; the rider's ankle torque held at
zero: the rider's own loop is two decades slower and barely moves it), and its damping
ratio is ζ = −Re λ / |λ|.  Where the mode is overdamped (no oscillatory eigenvalue at all)
ζ is taken as 1.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.plant import linear_plant
from euc_sim.errors import InputError
from euc_sim.model.parameters import Params

__all__ = ["ZETA_UNRESOLVED", "pitch_mode_damping", "damping_floor"]

#: Damping ratio the simulator gives the pitch mode when the log cannot resolve K_d:
#: the conventional well-damped second-order design value, chosen before looking at any
#: ride (not tuned on the held-out error).
ZETA_UNRESOLVED = 0.7


def pitch_mode_damping(p: Params, Kp: float, Kd: float) -> tuple[float, float]:
    """Damping ratio and natural frequency of the body pitch mode under the law (K_p, K_d).

    Parameters
    ----------
    p : Params
    Kp : float
        N·m/rad.
    Kd : float
        N·m·s/rad.

    Returns
    -------
    zeta : float
        −Re λ / |λ| of the fastest oscillatory eigenvalue; 1.0 when no eigenvalue oscillates.
    omega : float
        |λ|, rad/s (nan when no eigenvalue oscillates).
    """
    A, _ = linear_plant(p, MotorPD(Kp=Kp, Kd=Kd))
    lam = np.linalg.eigvals(A)
    osc = lam[np.abs(lam.imag) > 1e-9 * np.maximum(1.0, np.abs(lam))]
    if osc.size == 0:
        return 1.0, float("nan")
    fast = osc[np.argmax(np.abs(osc))]
    return float(-fast.real / abs(fast)), float(abs(fast))


def damping_floor(p: Params, Kp: float, zeta: float = ZETA_UNRESOLVED) -> float:
    """The smallest K_d ≥ 0 (N·m·s/rad) that gives the pitch mode the damping ratio ``zeta``.

    Parameters
    ----------
    p : Params
    Kp : float
        The measured proportional gain, N·m/rad (> 0).
    zeta : float
        Damping ratio in (0, 1).

    Returns
    -------
    float
        K_d, found by bracketing (doubling) and Brent's root search on ζ(K_d) − zeta;
        0.0 when the law is already that damped without K_d.

    Raises
    ------
    ValueError
        for ``Kp`` ≤ 0, ``zeta`` outside (0, 1), or no K_d below 1e6 N·m·s/rad reaching it.
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
