"""The energy balance over a window: one linear filter on both sides of the mass regression.

Integrating the power balance over a window T centred on t gives exactly::

    mean_T(P) = m·Δ_T(v²/2)/T + m·g·Δ_T(h)/T + c₁·mean_T(v) + c₃·mean_T(v³)
                + k_cu·mean_T(I_ph²) + P₀

with Δ_T x = x(t + T/2) − x(t − T/2): the moving mean of a derivative is the window's
difference over T, so no noisy speed is differentiated and the filter cannot bias the
coefficients (docs/identification.md).
"""

from __future__ import annotations

import numpy as np

from euc_sim.errors import InputError
from euc_sim.rides.grids.signals import window_samples
from euc_sim.stats import label_rows

__all__ = ["window_mean", "window_difference", "window_samples_odd"]


def window_samples_odd(window: float, rate: float) -> int:
    """Samples in a window of ``window`` s at ``rate`` Hz, rounded to an odd number ≥ 3."""
    if not (window > 0 and rate > 0):
        raise InputError(f"window and rate must be positive, got window={window!r} s, rate={rate!r} Hz")
    return window_samples(window, rate, 1)


def window_mean(x: np.ndarray, segment: np.ndarray, n: int) -> np.ndarray:
    """Centred trapezoidal moving mean of ``x`` over ``n`` samples (odd), segment by segment.

    Exact for the grid's piecewise-linear signals, so the window mean of a derivative equals
    :func:`window_difference`.  NaN where the window holds a non-finite value or leaves its segment.
    """
    x = np.asarray(x, float)
    out = np.full(x.shape, np.nan)
    h = n // 2
    for idx in label_rows(segment):
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
    """``(x(t + T/2) − x(t − T/2))/T``, T = (n − 1)/``rate``: the window mean of dx/dt (unit of x
    per s), segment by segment; NaN at segment ends and where an end is not finite.
    """
    x = np.asarray(x, float)
    out = np.full(x.shape, np.nan)
    h = n // 2
    T = (n - 1) / rate
    for idx in label_rows(segment):
        if idx.size < n:
            continue
        xs = x[idx]
        out[idx[h:idx.size - h]] = (xs[2 * h:] - xs[:-2 * h]) / T
    return out
