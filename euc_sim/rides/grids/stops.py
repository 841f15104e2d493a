"""Stops: where a logged wheel stands still long enough that nobody is balancing on it.

A real rider who stops for more than a moment puts a foot down (or has not stepped on
yet: most logs begin with the wheel switched on and standing).  The logs say so
(``python studies/stop_power.py``, docs/ride_simulation.md): at the stops of
:data:`T_STOP` s or more of the 20 shared logs that have them, the battery power's median
is 0–1 W (8–10 W on the four V9 logs, whose wheel draws that idling), its 90th percentile
at most 32 W, while at the shorter stands of the Begode and V9 logs the median is 9–31 W
(the motor works: somebody balances) and riding 190–3,200 W.  The Leaperkim and Nosfet
logs read 0 W at any stand, so they neither confirm nor refute it.

The simulated rider therefore does not balance through a stop: the ride is split at the
stops (:func:`find_stops`, :func:`moving_segments`); he rides each moving stretch from
rest with his memory (speed-error integral, delay buffer, predictor history) cleared, and
through the stop the wheel stands at rest, foot down, with no motor or ankle torque
(:func:`rest_rows`).  Without this a rider with a speed-error integral winds it up
against the rolling resistance through a long stop and rides the distance back and forth
(docs/ride_simulation.md, the calibrated Lynx 0 → 2 fall).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from euc_sim.errors import InputError

__all__ = ["V_STOP", "T_STOP", "find_stops", "moving_segments", "rest_rows"]

#: |v| below this is standing still, m/s (0.36 km/h; the logs read 0.00–0.02 m/s at a stop).
V_STOP = 0.1
#: A stand this long or longer is a stop, s.  Set from the battery power at stands (module
#: docstring), before the stop model was ridden on any pair: not fitted to the table.
T_STOP = 3.0


def find_stops(t: np.ndarray, v: np.ndarray, v_max: float = V_STOP,
               min_duration: float = T_STOP) -> list[tuple[int, int]]:
    """The stops of a profile: maximal runs of rows with |v| < ``v_max`` lasting ``min_duration`` or more.

    Parameters
    ----------
    t : array_like
        s, increasing.
    v : array_like
        m/s.
    v_max : float
        m/s, positive.
    min_duration : float
        s, non-negative: the run's span from its first to its last row.

    Returns
    -------
    list of (int, int)
        Index pairs (first, last) of each stop's rows, inclusive, in order.
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
    """The stretches between stops, each from the last row of a stop to the first of the next.

    Parameters
    ----------
    n : int
        Rows of the profile.
    stops : list of (int, int)
        :func:`find_stops`.

    Returns
    -------
    list of (int, int)
        (first, last) row of each stretch, inclusive, with at least two rows; a stretch
        starts and ends at rest except at the profile's own ends.
    """
    ends = [0] + [i for stop in stops for i in stop] + [n - 1]
    return [(a, b) for a, b in zip(ends[0::2], ends[1::2]) if b > a]


def rest_rows(t: np.ndarray, x: float, gamma: float, phi: float, v_ref: np.ndarray) -> pd.DataFrame:
    """The simulator's frame (:func:`euc_sim.simulation.engine.simulate` columns) of a wheel at rest, foot down.

    Parameters
    ----------
    t : array_like
        s, the control steps of the stop.
    x : float
        Where the wheel stands, m.
    gamma, phi : float
        Body and rider pitch held, rad (the rest trim).
    v_ref : array_like
        The plan at those steps, m/s (as the rider's frame records it).

    Returns
    -------
    pandas.DataFrame
        ``t, x, gamma, phi, x_dot, gamma_dot, phi_dot, M_d, M_h, v_ref``: rates and torques 0.
    """
    t = np.asarray(t, float)
    zero = np.zeros(t.size)
    return pd.DataFrame({"t": t, "x": np.full(t.size, float(x)), "gamma": np.full(t.size, float(gamma)),
                         "phi": np.full(t.size, float(phi)), "x_dot": zero, "gamma_dot": zero,
                         "phi_dot": zero, "M_d": zero, "M_h": zero,
                         "v_ref": np.asarray(v_ref, float)})
