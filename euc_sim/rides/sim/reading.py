"""The simulation read as a ride log is written: a reading at each of the log's own time stamps.

A simulated channel (1 ms steps) compared with a log (a reading every ~0.2 s, interpolated
onto the grid) must be read the same way, or its fast part reaches the comparison where
the log's never does (up to 7 dB more in the ~2 Hz band for battery power).  The rider fit
and the simulated ride both read through :func:`read_as_logged`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["READING_MEAN", "stamp_readings", "quantise", "read_as_logged"]

#: s: each reading of the simulated log is the mean of the simulation over this long before
#: its stamp (an app's reading is not an instant's value; 0.2 s is one 5 Hz interval).
READING_MEAN = 0.2


def stamp_readings(t_sim: np.ndarray, y: np.ndarray, stamps: np.ndarray) -> np.ndarray:
    """The readings of a uniformly sampled channel ``y`` (at ``t_sim`` s) at the log's ``stamps`` (s).

    Each is the mean over :data:`READING_MEAN` s ending at its stamp.  A stamp within that
    before the start or after the end reads the first or last full mean; NaN further outside.
    """
    mean = READING_MEAN
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
    """Readings ``x`` rounded to the log's step ``quantum`` (same unit) from a zero drawn by ``rng``
    uniformly over one step.
    """
    off = rng.uniform()
    return quantum * (np.round(np.asarray(x, float) / quantum + off) - off)


def read_as_logged(t_sim: np.ndarray, y: np.ndarray, stamps: np.ndarray, t_grid: np.ndarray,
                   quantum: float | None = None, rng: np.random.Generator | None = None) -> np.ndarray:
    """A simulated channel read at the log's stamps and put on the ride's grid as the log is.

    ``t_sim``, ``y`` as :func:`stamp_readings`; ``stamps`` the log's (repeats read once);
    written in the log's step ``quantum`` where given (:func:`quantise`, zero from ``rng``).  Returns the channel on ``t_grid`` (s), linearly interpolated
    between readings, NaN outside their span.
    """
    t_grid = np.asarray(t_grid, float)
    st = np.unique(np.asarray(stamps, float))
    r = stamp_readings(t_sim, y, st)
    ok = np.isfinite(r)
    if ok.sum() < 2:
        return np.full(t_grid.size, np.nan)
    st, r = st[ok], r[ok]
    if quantum:
        r = quantise(r, quantum, rng)
    out = np.interp(t_grid, st, r)
    out[(t_grid < st[0]) | (t_grid > st[-1])] = np.nan
    return out
