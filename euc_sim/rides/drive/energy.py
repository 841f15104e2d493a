"""The energy balance over a window: one linear filter on both sides of the mass regression.

Integrating the power balance ``P = m·d/dt(v²/2) + m·g·ḣ + c₁·v + c₃·v³ +
k_cu·I_ph² + P₀`` over a window of length T centred on t gives, exactly::

    mean_T(P) = m·Δ_T(v²/2)/T + m·g·Δ_T(h)/T + c₁·mean_T(v) + c₃·mean_T(v³)
                + k_cu·mean_T(I_ph²) + P₀

with ``Δ_T x = x(t + T/2) − x(t − T/2)``.  The moving mean is one linear filter
applied to every term, and the moving mean of a derivative *is* the window's
difference over T: no derivative of a noisy speed is taken and the filter
cannot bias the coefficients (the state-variable-filter idea, docs/identification.md).
If the model were complete every window would return the same mass; what
differs between windows is dynamics the model leaves out (logging latency, the
apps' own smoothing of current and speed), and :func:`euc_sim.rides.drive.mass.fit_mass`
carries that spread into the mass interval instead of choosing one window.
"""

from __future__ import annotations

import numpy as np

from euc_sim.errors import InputError
from euc_sim.stats import distinct

__all__ = ["window_mean", "window_difference", "window_samples_odd"]


def window_samples_odd(window: float, rate: float) -> int:
    """Samples in a window of ``window`` s at ``rate`` Hz, rounded to an odd number ≥ 3."""
    if not (window > 0 and rate > 0):
        raise InputError(f"window and rate must be positive, got window={window!r} s, rate={rate!r} Hz")
    n = max(3, int(round(window * rate)))
    return n + 1 if n % 2 == 0 else n


def _segments(segment: np.ndarray):
    seg = np.asarray(segment)
    for s in distinct(seg):
        yield np.flatnonzero(seg == s)


def window_mean(x: np.ndarray, segment: np.ndarray, n: int) -> np.ndarray:
    """Centred moving mean over ``n`` samples (odd), trapezoidal, segment by segment.

    The trapezoidal mean over T = (n − 1)/rate is exact for the piecewise-linear
    signals of the resampled grid, so the window mean of a derivative equals
    :func:`window_difference` to rounding.

    Parameters
    ----------
    x : array_like
        Signal on the uniform grid (any unit).
    segment : array_like of int
        Segment label of each sample; a window never crosses a boundary.
    n : int
        Window length in samples (odd).

    Returns
    -------
    numpy.ndarray
        Same unit as ``x``; NaN where the window holds a non-finite value or
        leaves its segment.
    """
    x = np.asarray(x, float)
    out = np.full(x.shape, np.nan)
    h = n // 2
    for idx in _segments(segment):
        if idx.size < n:
            continue
        xs = x[idx]
        fin = np.isfinite(xs)
        c = np.concatenate([[0.0], np.cumsum(np.where(fin, xs, 0.0))])
        cf = np.concatenate([[0], np.cumsum(fin)])
        ends = 0.5 * (np.where(fin, xs, 0.0)[:xs.size - n + 1] + np.where(fin, xs, 0.0)[n - 1:])
        mean = (c[n:] - c[:-n] - ends) / (n - 1)
        mean[(cf[n:] - cf[:-n]) < n] = np.nan
        out[idx[h:h + mean.size]] = mean
    return out


def window_difference(x: np.ndarray, segment: np.ndarray, n: int, rate: float) -> np.ndarray:
    """``(x(t + T/2) − x(t − T/2))/T`` with T = (n − 1)/rate: the window mean of dx/dt.

    Parameters
    ----------
    x : array_like
        Signal on the uniform grid.
    segment : array_like of int
        Segment labels (a window never crosses a boundary).
    n : int
        Window length in samples (odd).
    rate : float
        Grid rate, Hz.

    Returns
    -------
    numpy.ndarray
        Unit of x per second; NaN at segment ends and where an end is not finite.
    """
    x = np.asarray(x, float)
    out = np.full(x.shape, np.nan)
    h = n // 2
    T = (n - 1) / rate
    for idx in _segments(segment):
        if idx.size < n:
            continue
        xs = x[idx]
        out[idx[h:idx.size - h]] = (xs[2 * h:] - xs[:-2 * h]) / T
    return out
