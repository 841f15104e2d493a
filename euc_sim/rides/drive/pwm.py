"""The duty (PWM) a wheel's controller applies: the volts it needs, over the battery's.

The basic model (:mod:`euc_sim.rides.drive.drivetrain`) is a DC motor's::

    d·V = K_v·v + r_F·F                       (V)

back-EMF plus resistive drop.  A field-oriented controller on a real wheel adds
two effects that the logged duty of the Leaperkim Lynx shows plainly (and the
InMotion V9's less so):

- **dead time** ``c_dt·V·sign F``: while both switches of a bridge leg are off
  the phase current's own direction sets the leg's voltage, so the controller
  must add a duty ``c_dt = 2·t_dead·f_sw`` (a few %) in the direction of the
  current: on the Lynx the applied volts jump by about 14 V where the current
  changes sign, at any speed;
- **flux weakening** ``−c_fw·v·min(v, v_fw)``: at speed the controller drives a
  d-axis current against the magnets' flux, so the back-EMF per unit speed
  falls as speed rises, ``K_v − c_fw·v`` (Lynx at low current: 7.6 V/(m/s) at
  3 m/s, 5.9 at 19 m/s).  ``v_fw`` is the fastest speed of the fitted ride:
  beyond it the fall is not extrapolated (the controller's current limit,
  not in the log, bounds it), which keeps the envelope and the simulator's
  voltage limit on the safe side.

Each extra term is kept only when it lowers the blocked held-out RMS error of
the applied volts (10 contiguous blocks, each predicted from the other nine) by
``MIN_GAIN``, the selection :mod:`euc_sim.rides.drive.mass` uses for the mass's terms.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from euc_sim.stats import forward_select as select_by_heldout
from euc_sim.rides.drive.mass import heldout_rmse

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
    """The model's columns, volts per unit coefficient, one per name.

    Parameters
    ----------
    v : numpy.ndarray
        The wheel's speed reading, m/s.
    F : numpy.ndarray
        Wheel force from battery power, P/v, N.
    V : numpy.ndarray
        Battery voltage, V.
    names : sequence of str
        Of :data:`BASE` and :data:`EXTRA`.
    v_fw : float
        Speed, m/s, above which the flux weakening no longer grows.

    Returns
    -------
    numpy.ndarray
        rows × len(names): ``K_v`` → v, ``r_F`` → F, ``dead_time`` → V·sign F
        (with the coefficient, a duty), ``flux_weakening`` → −v·min(v, v_fw).
    """
    make = {"K_v": lambda: v, "r_F": lambda: F, "dead_time": lambda: V * np.sign(F),
            "flux_weakening": lambda: -v * np.minimum(v, v_fw)}
    return np.column_stack([make[n]() for n in names])


def select_pwm_terms(v: np.ndarray, F: np.ndarray, V: np.ndarray, duty: np.ndarray,
                     t: np.ndarray) -> tuple[list[str], list[dict]]:
    """Forward selection of :data:`EXTRA` by blocked held-out RMSE of the applied volts d·V.

    Returns
    -------
    names : list of str
        :data:`BASE` plus the kept terms, in the order kept.
    history : list of dict
        ``{"term", "heldout_rmse"}`` (V) after each step, the base model first.
    """
    y = duty * V
    return select_by_heldout(lambda names: heldout_rmse(pwm_columns(v, F, V, names), y, t, True),
                          list(BASE), list(EXTRA), MIN_GAIN)


def back_emf(coef: Mapping[str, float], speed) -> np.ndarray:
    """The back-EMF at ``speed`` (m/s, magnitude used), V: K_v·v − c_fw·v·min(v, v_fw)."""
    v = np.abs(np.asarray(speed, float))
    c = coef.get("flux_weakening", 0.0)
    return coef["K_v"] * v - c * v * np.minimum(v, coef.get("v_fw", np.inf))
