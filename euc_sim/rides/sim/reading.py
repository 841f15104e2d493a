"""The simulation read as a ride log is written: a reading at each of the log's own time stamps.

A wheel app writes a reading every 0.2 s or so, at irregular stamps, and the ride's grid is
interpolated between them (:func:`euc_sim.rides.grids.signals.resample`).  A simulated channel
(sampled every step, 1 ms) compared with such a log must be read the same way, or its fast
part reaches the comparison where the log's never does: sampled on the 10 Hz grid directly,
a simulated rider's battery power carries up to 7 dB more in the fastest band (~2 Hz) than
read at the log's stamps and interpolated as the log is (the linear interpolation between
5 Hz readings alone passes 0.57 of a 2 Hz swing).  The rider fit
(:mod:`euc_sim.rides.rider.rider_fit`) and the simulated ride (:mod:`euc_sim.rides.sim.simulate`)
both read through :func:`stamp_readings` and :func:`read_as_logged`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["READING_MEAN", "stamp_readings", "quantise", "read_as_logged"]

#: s: each reading of the simulated log is the mean of the simulation over this long before
#: its stamp (an app's reading is not an instant's value; 0.2 s is one 5 Hz interval).
READING_MEAN = 0.2


def stamp_readings(t_sim: np.ndarray, y: np.ndarray, stamps: np.ndarray,
                   mean: float = READING_MEAN) -> np.ndarray:
    """The readings of a uniformly sampled simulated channel at the log's stamps.

    Parameters
    ----------
    t_sim, y : array_like
        The simulation's time, s (uniform step), and channel (any unit).
    stamps : array_like
        The log's time stamps, s, increasing.
    mean : float
        s: each reading is the mean of the samples over this long ending at its stamp (at
        least one sample).

    Returns
    -------
    numpy.ndarray
        (len(stamps),) readings, the channel's unit.  A stamp within ``mean`` of the
        simulation's start reads the first full mean, one within ``mean`` after its end the
        last (a simulation run to the grid's end stops short of the log's last stamp); NaN
        at a stamp further outside.
    """
    t_sim = np.asarray(t_sim, float)
    y = np.asarray(y, float)
    stamps = np.asarray(stamps, float)
    if t_sim.size < 2:
        return np.full(stamps.size, np.nan)
    dt = float(np.median(np.diff(t_sim)))
    n = min(max(1, int(round(mean / dt))), t_sim.size)
    cs = np.cumsum(np.r_[0.0, y])
    means = (cs[n:] - cs[:-n]) / n                    # mean of the n samples ending at t_sim[k]
    t_end = t_sim[n - 1:]
    out = np.interp(stamps, t_end, means)
    out[(stamps < t_sim[0] - mean) | (stamps > t_sim[-1] + mean)] = np.nan
    return out


def quantise(x: np.ndarray, quantum: float, rng: np.random.Generator) -> np.ndarray:
    """Readings written in a log's steps (0.1° pitch, 0.1 A current), from an unknown zero.

    Parameters
    ----------
    x : array_like
        Readings (any unit).
    quantum : float
        The log's step, the readings' unit (:func:`euc_sim.rides.grids.rider_features.reading_step`).
    rng : numpy.random.Generator
        Draws the steps' zero, uniform over one step.

    Returns
    -------
    numpy.ndarray
        A new array: each reading rounded to the nearest step.
    """
    off = rng.uniform()
    return quantum * (np.round(np.asarray(x, float) / quantum + off) - off)


def read_as_logged(t_sim: np.ndarray, y: np.ndarray, stamps: np.ndarray, t_grid: np.ndarray,
                   mean: float = READING_MEAN, quantum: float | None = None,
                   rng: np.random.Generator | None = None) -> np.ndarray:
    """A simulated channel read at the log's stamps and put on the ride's grid as the log is.

    Parameters
    ----------
    t_sim, y, mean :
        As :func:`stamp_readings`.
    stamps : array_like
        The log's time stamps, s (repeated stamps are read once).
    t_grid : array_like
        The ride's grid, s.
    quantum : float, optional
        The step the log writes this channel in (:func:`quantise`): the readings are
        written in it too.
    rng : numpy.random.Generator, optional
        For the steps' zero (default seed 0).

    Returns
    -------
    numpy.ndarray
        (len(t_grid),) the channel on the grid, linearly interpolated between its readings;
        NaN outside the readings' span (before the simulation starts or after it ends).
    """
    t_grid = np.asarray(t_grid, float)
    st = np.unique(np.asarray(stamps, float))
    r = stamp_readings(t_sim, y, st, mean)
    ok = np.isfinite(r)
    if ok.sum() < 2:
        return np.full(t_grid.size, np.nan)
    st, r = st[ok], r[ok]
    if quantum:
        r = quantise(r, quantum, rng if rng is not None else np.random.default_rng(0))
    out = np.interp(t_grid, st, r)
    out[(t_grid < st[0]) | (t_grid > st[-1])] = np.nan
    return out
