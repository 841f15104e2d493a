"""The duty (PWM) a wheel's controller applies: the volts it needs, over the battery's.

The DC motor's d·V = K_v·v + r_F·F (back-EMF plus resistive drop), with two
field-oriented-controller terms kept when they lower the blocked held-out RMS error of
the applied volts by :data:`MIN_GAIN`: dead time ``c_dt·V·sign F`` (c_dt = 2·t_dead·f_sw)
and flux weakening ``−c_fw·v·min(v, v_fw)`` (the back-EMF per speed falling with speed;
v_fw the fitted ride's fastest speed, not extrapolated beyond).  See docs/drivetrain.md.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from euc_sim.stats import forward_select as select_by_heldout
from euc_sim.rides.drive.mass import heldout_folds, heldout_rmse

__all__ = ["BASE", "EXTRA", "MIN_GAIN", "pwm_columns", "select_pwm_terms", "back_emf"]

#: Always in the model: back-EMF (K_v, V per m/s) and resistive drop (r_F, V/N).
BASE = ("K_v", "r_F")
#: Offered to the selection: name -> (meaning, unit of the coefficient).
EXTRA: dict[str, tuple[str, str]] = {
    "dead_time": ("duty added in the current's direction (dead time, 2·t_dead·f_sw)", "dimensionless"),
    "flux_weakening": ("fall of the back-EMF per speed with speed (d-axis current)",
                       "V/(m/s)^2"),
}
#: Fraction of the held-out RMS error a term must remove to be kept.
MIN_GAIN = 0.005


def pwm_columns(v: np.ndarray, F: np.ndarray, V: np.ndarray,
                names=BASE + tuple(EXTRA), v_fw: float = np.inf) -> np.ndarray:
    """The model's columns, volts per unit coefficient: ``K_v`` → v (m/s), ``r_F`` → F (P/v, N),
    ``dead_time`` → V·sign F, ``flux_weakening`` → −v·min(v, ``v_fw``); rows × len(names).
    """
    make = {"K_v": lambda: v, "r_F": lambda: F, "dead_time": lambda: V * np.sign(F),
            "flux_weakening": lambda: -v * np.minimum(v, v_fw)}
    return np.column_stack([make[n]() for n in names])


def select_pwm_terms(v: np.ndarray, F: np.ndarray, V: np.ndarray, duty: np.ndarray,
                     t: np.ndarray) -> tuple[list[str], list[dict]]:
    """Forward selection of :data:`EXTRA` by blocked held-out RMSE of the applied volts d·V: the
    names kept (:data:`BASE` first) and ``{"term", "heldout_rmse"}`` (V) after each step.
    """
    y, label = duty * V, heldout_folds(t, True)
    return select_by_heldout(lambda names: heldout_rmse(pwm_columns(v, F, V, names), y, label, True),
                          list(BASE), list(EXTRA), MIN_GAIN)


def back_emf(coef: Mapping[str, float], speed) -> np.ndarray:
    """The back-EMF at ``speed`` (m/s, magnitude used), V: K_v·v − c_fw·v·min(v, v_fw)."""
    v = np.abs(np.asarray(speed, float))
    c = coef.get("flux_weakening", 0.0)
    return coef["K_v"] * v - c * v * np.minimum(v, coef.get("v_fw", np.inf))
