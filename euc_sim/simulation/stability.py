"""Stability of the closed loops: the plant's linearisation with the motor PD and the rider designed on it."""

from __future__ import annotations

import numpy as np

from euc_sim.controllers.design import delayed_closed_loop_radius, design_rider
from euc_sim.controllers.plant import rider_plant
from euc_sim.controllers.motor import MotorPD
from euc_sim.model.linearize import check_against_mujoco, delay_margin, jacobians, numeric_jacobians
from euc_sim.model.parameters import Params, TABLE3


def _eig_list(A: np.ndarray) -> list[list[float]]:
    ev = np.linalg.eigvals(A)
    ev = ev[np.lexsort((ev.imag, ev.real))]
    return [[float(e.real), float(e.imag)] for e in ev]


def stability_report(p: Params = TABLE3, motor=None, rider=None, speed: float = 0.0,
                     check_mujoco: bool = True) -> dict:
    """Linearisation at upright riding at ``speed``, m/s, its eigenvalues and the rider's delay margin.

    JSON-ready: eigenvalues ([re, im], 1/s) of the open loop, with the motor PD and with the
    rider; the delay margins and the discrete loop with the rider's delay and predictor; the
    Jacobian checks (against ``mjd_transitionFD`` with ``check_mujoco``).  ``motor`` and
    ``rider`` default to the default gains and :func:`~euc_sim.controllers.design.design_rider`.
    """

    motor = motor or MotorPD()
    rider = rider or design_rider(p, motor)
    y0 = np.zeros(6)
    y0[3] = speed
    A, B = jacobians(p, y0)
    An, Bn = numeric_jacobians(p, y0)
    K = np.asarray(rider.K, dtype=float)[None, :]
    As, Bs = rider_plant(p, motor, K.size == 6, speed)
    Acl = As - Bs @ K
    tau, wc = delay_margin(As, Bs, K)
    rho = delayed_closed_loop_radius(p, motor, rider, speed=speed)
    eig = {"open_loop": _eig_list(A), "motor_pd": _eig_list(As[:5, :5]), "motor_pd_and_rider": _eig_list(Acl)}
    out = {
        "operating_point": {"speed": speed, "gamma": 0.0, "phi": 0.0},
        "state_order": ["x", "gamma", "phi", "x_dot", "gamma_dot", "phi_dot"],
        "reduced_state_order": ["x_dot", "gamma", "phi", "gamma_dot", "phi_dot", "x_int"][:K.size],
        "motor": motor.as_dict(),
        "rider": rider.as_dict(),
        "eigenvalues": eig,
        "max_real_part": {k: max(e[0] for e in ev) for k, ev in eig.items()},
        "rider_loop": {
            "delay_margin_without_predictor": tau,
            "crossover_frequency": wc,
            "reaction_delay": rider.delay,
            "discrete_spectral_radius_with_delay": rho,
            "stable_with_delay": bool(rho < 1.0),
        },
        "jacobian_check": {
            "analytic_vs_central_difference": float(max(np.max(np.abs(A - An)), np.max(np.abs(B - Bn)))),
        },
    }
    if check_mujoco:
        out["jacobian_check"]["analytic_vs_mjd_transitionFD"] = check_against_mujoco(p)
    return out
