"""The logged wheel speed as a simulator input (every gap bridged)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from euc_sim.rides.signals import as_log, resample, sg

__all__ = ["speed_profile", "write_speed_profile"]


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
