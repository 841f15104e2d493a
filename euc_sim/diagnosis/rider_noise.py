"""The rider's motor-noise level read from the recorded ankle torque.

The simulator's rider adds an Ornstein–Uhlenbeck torque of σ and correlation time τ to his
smooth delayed command (:func:`euc_sim.controllers.rider.motor_noise`); sampled, it is
AR(1) with ρ = exp(−Δt/τ), whose second difference has variance
σ² (6 − 4ρ_a − 4ρ_b + 2ρ_a ρ_b), so the recorded M_h's second differences give σ̂ without
any state.  τ is the twin rider's (``Rider.noise_tau``).  Accuracy:
docs/coverage.md#the-twin-carries-the-riders-own-motor-noise-the-unexplained-floor.
"""

from __future__ import annotations

import math
import zlib

import numpy as np

from euc_sim.errors import InputError

__all__ = ["motor_noise_level", "recording_seed"]


def motor_noise_level(t: np.ndarray, M_h: np.ndarray, tau: float) -> float:
    """σ̂ = √(mean (ΔΔM_h)² / mean (6 − 4ρ_a − 4ρ_b + 2ρ_a ρ_b)) of a recorded ankle torque, N·m.

    ``t`` (s, increasing) and ``M_h`` (N·m) of equal length, ``tau`` > 0 (s); NaN with fewer
    than 3 finite samples.
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
    """A seed from the recording's content (CRC-32 of ``t`` and ``M_h``, or ``t``) and the draw's index."""
    cols = [c for c in ("t", "M_h") if c in raw.columns]
    crc = 0
    for c in cols:
        crc = zlib.crc32(np.ascontiguousarray(raw[c].to_numpy(float)).tobytes(), crc)
    return int((crc + 7919 * int(draw)) % (2**31 - 1)) + 1
