"""The rider's motor-noise level read from the recorded ankle torque.

The simulator's rider adds an Ornstein–Uhlenbeck torque n(t) of standard deviation σ and
correlation time τ to his delayed law (:func:`euc_sim.controllers.rider.motor_noise`): the recorded
M_h is u(t) + n(t), u the command.  The command reacts to states at least the reaction
delay old and passes through the rider's body, so it is smooth at the recording's sampling
interval, while n, sampled every Δt, is an AR(1) sequence with ρ = exp(−Δt/τ) whose second
difference n_{k+1} − 2 n_k + n_{k−1} has variance σ² (6 − 4ρ_a − 4ρ_b + 2ρ_a ρ_b)
(ρ_a, ρ_b of the two intervals; 2σ²(1 − ρ)(3 − ρ) at a uniform rate).  The mean square of
the recorded M_h's second difference over that factor is σ̂²: the command contributes its
own (small) second difference, the noise the rest.  It needs no state, so the recording's
sensor noise (which the torques do not carry) does not enter.

Accuracy: see docs/coverage.md#the-twin-carries-the-riders-own-motor-noise-the-unexplained-floor.
The level assumes the correlation time of the twin's rider
(``Rider.noise_tau``, 0.05 s): the twin carries the noise whose second differences the
recording shows.

The twin's draw is seeded from the recording itself (:func:`recording_seed`): the same
recording gives the same twin.
"""

from __future__ import annotations

import math
import zlib

import numpy as np

from euc_sim.errors import InputError

__all__ = ["motor_noise_level", "recording_seed"]


def motor_noise_level(t: np.ndarray, M_h: np.ndarray, tau: float) -> float:
    """The standard deviation of the rider's OU motor noise in a recorded ankle torque, N·m.

    Parameters
    ----------
    t : numpy.ndarray, shape (N,)
        Sample times, s (increasing; N ≥ 3).
    M_h : numpy.ndarray, shape (N,)
        Recorded ankle torque (applied: command plus noise), N·m.
    tau : float
        Correlation time of the noise, s.

    Returns
    -------
    float
        σ̂ = √(mean (ΔΔM_h)² / mean (6 − 4ρ_a − 4ρ_b + 2ρ_a ρ_b)), ρ = exp(−Δt/τ) of each
        interval; NaN when fewer than 3 finite samples.

    Raises
    ------
    ValueError
        when ``tau`` is not positive or the arrays differ in length.
    """
    t, y = np.asarray(t, float), np.asarray(M_h, float)
    if not (math.isfinite(tau) and tau > 0):
        raise InputError(f"tau must be a positive number of seconds, got {tau!r}")
    if t.shape != y.shape:
        raise ValueError(f"t and M_h differ in length: {t.size} and {y.size}")
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    if t.size < 3:
        return math.nan
    d2 = y[2:] - 2.0 * y[1:-1] + y[:-2]
    ra = np.exp(-np.diff(t)[:-1] / tau)
    rb = np.exp(-np.diff(t)[1:] / tau)
    g = 6.0 - 4.0 * ra - 4.0 * rb + 2.0 * ra * rb
    return float(math.sqrt(np.mean(d2 * d2) / np.mean(g)))


def recording_seed(raw, draw: int = 0) -> int:
    """A seed for the twin's noise from the recording's own content (CRC-32 of its
    ``t`` and ``M_h`` columns, or ``t`` alone) and the draw's index: deterministic,
    different between recordings and between draws."""
    cols = [c for c in ("t", "M_h") if c in raw.columns]
    crc = 0
    for c in cols:
        crc = zlib.crc32(np.ascontiguousarray(raw[c].to_numpy(float)).tobytes(), crc)
    return int((crc + 7919 * int(draw)) % (2**31 - 1)) + 1
