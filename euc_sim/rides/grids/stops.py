"""Stops: where a logged wheel stands still long enough that nobody is balancing on it.

At stands of :data:`T_STOP` s or more the shared logs' battery power is near idle (the
rider has a foot down); see docs/ride_simulation.md.  So the simulated rider does not
balance through a stop: the ride is split at the stops (:func:`find_stops`,
:func:`moving_segments`), each moving stretch ridden from rest with the rider's memory
cleared, and through the stop the wheel stands at rest with no torque (:func:`rest_rows`).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from euc_sim.errors import InputError

__all__ = ["V_STOP", "T_STOP", "find_stops", "moving_segments", "rest_rows"]

#: |v| below this is standing still, m/s (0.36 km/h; the logs read 0.00–0.02 m/s at a stop).
V_STOP = 0.1
#: A stand this long or longer is a stop, s: from the battery power at stands (module docstring).
T_STOP = 3.0


def find_stops(t: np.ndarray, v: np.ndarray, v_max: float = V_STOP,
               min_duration: float = T_STOP) -> list[tuple[int, int]]:
    """The stops of a profile: (first, last) inclusive row pairs of maximal runs with
    |v| < ``v_max`` (m/s) spanning ``min_duration`` s or more (``t`` s, increasing).
    """
    t, v = np.asarray(t, float), np.asarray(v, float)
    if not (math.isfinite(v_max) and v_max > 0):
        raise InputError(f"v_max must be a positive number of m/s, got {v_max!r}")
    if not (math.isfinite(min_duration) and min_duration >= 0):
        raise InputError(f"min_duration must be a non-negative number of s, got {min_duration!r}")
    still = np.abs(v) < v_max
    edges = np.diff(np.concatenate([[0], still.astype(np.int8), [0]]))
    first, after = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(int(a), int(b) - 1) for a, b in zip(first, after) if t[b - 1] - t[a] >= min_duration]


def moving_segments(n: int, stops: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """(first, last) inclusive rows of the ``n``-row profile's stretches between ``stops``
    (each from a stop's last row to the next's first), at least two rows each.
    """
    ends = [0] + [i for stop in stops for i in stop] + [n - 1]
    return [(a, b) for a, b in zip(ends[0::2], ends[1::2]) if b > a]


def rest_rows(t: np.ndarray, x: float, gamma: float, phi: float, v_ref: np.ndarray) -> pd.DataFrame:
    """The simulator's frame of a wheel at rest at ``x`` m, foot down: pitches ``gamma``, ``phi``
    (rad) held, ``v_ref`` (m/s) recorded, every rate and torque 0, on the steps ``t`` (s).
    """
    t = np.asarray(t, float)
    zero = np.zeros(t.size)
    return pd.DataFrame({"t": t, "x": np.full(t.size, float(x)), "gamma": np.full(t.size, float(gamma)),
                         "phi": np.full(t.size, float(phi)), "x_dot": zero, "gamma_dot": zero,
                         "phi_dot": zero, "M_d": zero, "M_h": zero,
                         "v_ref": np.asarray(v_ref, float)})
