"""The logged wheel speed as a simulator input (every gap bridged)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from euc_sim.rides.signals import as_log, resample, sg

__all__ = ["speed_profile", "write_speed_profile", "rider_plan", "PLAN_WINDOW"]

#: The rider's plan: the logged speed smoothed over this many seconds.  The logged speed
#: holds the rider's own sway; a simulated rider told to follow it corrects every wobble
#: as if intended (on the concealed-rider ride of ``scripts/rider_calibration.py``, tuning
#: seed 11, the 0.15-0.6 Hz bands of power, torque and pitch come out 3-4 times the log's
#: with the 1.5 s-smoothed speed as the plan, within 10 % with the 6 s-smoothed one).
PLAN_WINDOW = 6.0


def speed_profile(log, rate: float = 10.0, window: float = 1.5, polyorder: int = 2) -> pd.DataFrame:
    """The logged wheel speed as a simulator input: ``DataFrame(t, v)``.

    Uniform grid at ``rate`` Hz from t = 0, speed in m/s smoothed by the same
    Savitzky–Golay fit as :func:`ride_signals`.  **Every gap is bridged** by linear
    interpolation here (a simulation needs a continuous profile); the gaps
    bridged are listed in ``result.attrs["notes"]``.

    Parameters
    ----------
    log : RideLog or path
    rate : float
        Hz.
    window : float
        s.
    polyorder : int

    Returns
    -------
    pandas.DataFrame
        Columns ``t`` (s, strictly increasing) and ``v`` (m/s).
    """
    log = as_log(log)
    raw, _ = resample(log, rate, max_gap=math.inf)
    t = log.data["t"].to_numpy()
    gaps = np.flatnonzero(np.diff(t) > 1.0)
    v = sg(raw["v"].to_numpy(), np.zeros(len(raw), int), rate, window, polyorder)
    out = pd.DataFrame({"t": raw["t"].to_numpy(), "v": v})
    out.attrs["notes"] = [f"gap of {t[i + 1] - t[i]:.2f} s at t = {t[i]:.2f} s bridged linearly"
                          for i in gaps]
    out.attrs["source"] = log.path
    return out


def write_speed_profile(log, path, rate: float = 10.0, window: float = 1.5) -> Path:
    """Write :func:`speed_profile` as a CSV (``t,v``) atomically, for the simulator.

    Returns
    -------
    pathlib.Path
    """
    from euc_sim.io import atomic_write

    prof = speed_profile(log, rate, window)
    return atomic_write(path, lambda p: prof.to_csv(p, index=False, float_format="%.6f"))


def rider_plan(t: np.ndarray, v: np.ndarray, window: float = PLAN_WINDOW) -> np.ndarray:
    """The speed the rider means to ride: the logged speed smoothed by a quadratic
    Savitzky–Golay fit over ``window`` s.

    Parameters
    ----------
    t : numpy.ndarray
        Uniform time grid, s.
    v : numpy.ndarray
        Logged speed on ``t``, m/s.
    window : float
        Smoothing window, s (default :data:`PLAN_WINDOW`).

    Returns
    -------
    numpy.ndarray
        The planned speed on ``t``, m/s.
    """
    t = np.asarray(t, float)
    rate = 1.0 / float(np.median(np.diff(t)))
    return sg(np.asarray(v, float), np.zeros(t.size, int), rate, window, 2)
