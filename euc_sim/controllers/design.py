"""Design of the rider's gains with python-control.

K minimises ∫ sᵀQs + R M_h² (``control.lqr``) on the plant of
:mod:`euc_sim.controllers.plant`, Q and R from the largest tolerable deviations (Bryson's
rule, :data:`DEFAULT_SCALES`); :func:`delayed_closed_loop_radius` checks the sampled loop
with the delay buffer and the predictor exactly as the simulation runs it.
"""

from __future__ import annotations

import math

import numpy as np

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.lateral import delayed_loop
from euc_sim.controllers.rider import Rider
from euc_sim.controllers.plant import has_integral, predictor_rows, rider_plant
from euc_sim.errors import InputError
from euc_sim.model.linearize import discretize
from euc_sim.model.parameters import Params, TABLE3

__all__ = ["DEFAULT_SCALES", "STATE_NAMES", "design_rider",
           "delayed_closed_loop_matrix", "delayed_closed_loop_radius", "delay_tolerance"]

#: Bryson's-rule scales: speed error (m/s), pitch errors (rad), their rates (rad/s; None:
#: not weighted), the speed error's integral (m; None: no integral action), ankle torque (N·m).
DEFAULT_SCALES = {"x_dot": 0.15, "gamma": 0.2, "phi": 0.1, "gamma_dot": None, "phi_dot": None,
                  "x_int": 0.5, "M_h": 5.0}
STATE_NAMES = ("x_dot", "gamma", "phi", "gamma_dot", "phi_dot", "x_int")


def design_rider(p: Params = TABLE3, motor: MotorPD | None = None, delay: float = 0.15,
                 scales: dict | None = None, **rider_settings) -> Rider:
    """LQR rider (M_h = −K s) on the linearised loop with the motor PD in it.

    ``delay``: the rider's reaction delay, s; ``scales``: overrides of :data:`DEFAULT_SCALES`
    (``x_int`` None: no integral state); ``rider_settings``: other :class:`Rider` fields.
    """
    import control  # deferred: loads control (1.6 s)

    motor = motor or MotorPD()
    sc = dict(DEFAULT_SCALES)
    sc.update(scales or {})
    integral = sc["x_int"] is not None
    A, B = rider_plant(p, motor, integral)
    names = STATE_NAMES[:6 if integral else 5]
    Q = np.diag([0.0 if sc[n] is None else 1.0 / sc[n] ** 2 for n in names])
    R = np.array([[1.0 / sc["M_h"] ** 2]])
    K, _, E = control.lqr(A, B, Q, R)
    if np.max(np.real(E)) >= 0:  # pragma: no cover - lqr returns a stabilising gain
        raise InputError(f"LQR design is not stabilising: eigenvalues {E}")
    return Rider(K=tuple(float(k) for k in np.asarray(K).ravel()), delay=delay, **rider_settings)


def delayed_closed_loop_matrix(p: Params, motor: MotorPD, rider: Rider, dt: float,
                               true_delay: float | None = None, speed: float = 0.0) -> np.ndarray:
    """Transition matrix of the sampled loop with the delay buffer and the predictor
    (:func:`~euc_sim.controllers.lateral.delayed_loop`).

    State (s_k, …, s_{k−D}, δu_{k−1}, …, δu_{k−n}), D = ``true_delay``/dt (default the
    rider's) and n = rider.delay/dt; ``dt``: control period, s.  The plant is linearised at
    ``speed``, m/s; the rider's predictor keeps his own model (as :mod:`euc_sim.controllers.rider`).
    """
    K = np.asarray(rider.K, dtype=float)
    A, B = rider_plant(p, motor, has_integral(K), speed)
    Phi, Gam = discretize(A, B, dt)
    n = int(round(rider.delay / dt))
    D = n if true_delay is None else int(round(true_delay / dt))
    if rider.predictor and n > 0:
        KPn, KG = predictor_rows(p, motor, K, dt, n)
    else:
        KPn, KG = K, np.zeros(n)
    return delayed_loop(Phi, Gam, KPn.reshape(1, -1), KG.reshape(1, -1), D, 0)


def delayed_closed_loop_radius(p: Params = TABLE3, motor: MotorPD | None = None, rider: Rider | None = None,
                               dt: float = 0.005, true_delay: float | None = None, speed: float = 0.0) -> float:
    """Spectral radius of :func:`delayed_closed_loop_matrix` at ``speed``, m/s (< 1: stable); ``dt``
    5 ms keeps it small."""
    motor = motor or MotorPD()
    rider = rider or design_rider(p, motor)
    T = delayed_closed_loop_matrix(p, motor, rider, dt, true_delay, speed)
    return float(np.max(np.abs(np.linalg.eigvals(T))))


def delay_tolerance(p: Params = TABLE3, motor: MotorPD | None = None,
                    rider: Rider | None = None) -> tuple[float, float]:
    """(lo, hi), s: the actual delays up to 0.6 s on a 5 ms grid the rider (his predictor tuned to
    rider.delay) survives, searched outward from his own; NaNs if unstable at it.
    """
    motor = motor or MotorPD()
    rider = rider or design_rider(p, motor)
    dt = 0.005
    n = int(round(rider.delay / dt))
    stable = lambda D: delayed_closed_loop_radius(p, motor, rider, dt, D * dt) < 1.0  # noqa: E731
    if not stable(n):
        return (math.nan, math.nan)
    lo = n
    while lo > 0 and stable(lo - 1):
        lo -= 1
    hi = n
    while (hi + 1) * dt <= 0.6 and stable(hi + 1):
        hi += 1
    return lo * dt, hi * dt
