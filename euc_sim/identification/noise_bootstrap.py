"""What the measurement noise does to h: a parametric bootstrap over the recording's own noise.

Each measured column is split into a smooth part (Savitzky–Golay, :data:`BASE_WINDOW`) and
white noise of estimated σ; replicates are the smooth part plus fresh noise, identified
like the recording.  Their spread is ĥ's spread due to the noise and their mean minus the
smooth part's h its errors-in-variables bias (:class:`NoiseSpread`), which
:func:`euc_sim.identification.h_fit.with_noise` adds to the interval
(docs/coverage.md#where-the-error-of-h-comes-from).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.signal import savgol_coeffs, savgol_filter

from euc_sim.errors import InputError
from euc_sim.model.parameters import Params
from euc_sim.identification.processing import (Kinematics, Smoothing, kinematics, sample_period,
                                               savgol_derivatives)
from euc_sim.identification.recordings import is_mocap

#: Smooth part of a measured column: Savitzky–Golay window (s) and order (passes ~1/6 of white noise).
BASE_WINDOW = 0.5
BASE_ORDER = 5
#: Columns that carry measurement noise (whichever a recording has).
NOISY_COLUMNS = ("x", "gamma", "phi", "psi", "theta", "C_X", "C_Y", "C_Z", "E_X", "E_Y", "E_Z",
                 "G_X", "G_Y", "G_Z")


#: Replicates processed at once on the state-level path (memory: grid × chunk × samples).
_CHUNK = 20


def _state_level(df: pd.DataFrame, kin_kw: dict) -> bool:
    """Whether :func:`kinematics` differentiates the recorded x, γ, φ directly."""
    src = kin_kw.get("source", "auto")
    return src == "state" or (src == "auto" and not is_mocap(df))


def _window_samples(dt: float) -> int:
    n = int(round(BASE_WINDOW / dt))
    n += 1 - n % 2
    return max(n, BASE_ORDER + 2 + (BASE_ORDER % 2))


def split_noise(y: np.ndarray, dt: float) -> tuple[np.ndarray, float]:
    """A measured column (N,) at period ``dt`` (s) as (smooth part, white-noise σ̂), both in y's unit.

    A Savitzky–Golay projection of centre weight c₀ leaves 1 − c₀ of white noise's variance,
    so σ̂² = mean(residual²)/(1 − c₀) over the interior.
    """
    y = np.asarray(y, dtype=float)
    w = min(_window_samples(dt), len(y) - 1 + len(y) % 2)
    if w <= BASE_ORDER:
        return y.copy(), 0.0
    smooth = savgol_filter(y, w, BASE_ORDER, mode="interp")
    c0 = float(savgol_coeffs(w, BASE_ORDER)[w // 2])
    r = (y - smooth)[w // 2: len(y) - w // 2]
    return smooth, float(math.sqrt(np.mean(r ** 2) / (1.0 - c0))) if r.size else 0.0


#: Noise replicates per recording (``--noise-replicates``): the spread of ĥ to about ±11 %.
N_REPLICATES = 40
#: Step of the grid on which replicates are minimised, m.
FINE_STEP = 0.001


def replicate_grid(bounds: tuple[float, float]) -> np.ndarray:
    """The grid of h on which replicates are minimised: the search bounds every
    :data:`FINE_STEP`, m."""
    lo, hi = map(float, bounds)
    return np.linspace(lo, hi, int(round((hi - lo) / FINE_STEP)) + 1)


def sum_squares_near(rp, grid: np.ndarray, h_ref: float) -> np.ndarray:
    """Σ_t (M_d,1 − M_d,2)² on ``grid`` (..., K), N²·m², with D's variation along the ride frozen at ``h_ref``.

    With D_t(h) ≈ D_t(h_ref)·D̄(h)/D̄(h_ref) the sum is (D̄(h_ref)/D̄(h))² times a quartic in h
    whose five coefficients are sums over the ride.
    """
    w = 1.0 / (rp.D[0] + h_ref * rp.D[1]) ** 2
    P0, P1, P2 = rp.P[0], rp.P[1], rp.P[2]
    c = [np.sum(w * x, axis=-1)[..., None] for x in
         (P0 * P0, 2 * P0 * P1, P1 * P1 + 2 * P0 * P2, 2 * P1 * P2, P2 * P2)]
    h = np.asarray(grid, dtype=float)
    quartic = c[0] + h * (c[1] + h * (c[2] + h * (c[3] + h * c[4])))
    d_ref = float(np.mean(rp.D[0] + h_ref * rp.D[1]))
    d_h = float(np.mean(rp.D[0])) + h * float(np.mean(rp.D[1]))
    return quartic * (d_ref / d_h) ** 2


def grid_minimum(grid: np.ndarray, J: np.ndarray) -> np.ndarray:
    """Minimiser along the last axis of J on a (non-uniform) grid, refined by the parabola
    through the lowest sample and its neighbours, m."""
    J = np.atleast_2d(J)
    k = np.clip(np.argmin(J, axis=-1), 1, len(grid) - 2)
    r = np.arange(J.shape[0])
    x0, x1, x2 = grid[k - 1], grid[k], grid[k + 1]
    y0, y1, y2 = J[r, k - 1], J[r, k], J[r, k + 1]
    num = (x1 - x0) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y1 - y0)
    den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0)
    ok = np.abs(den) > 1e-300
    step = np.where(ok, 0.5 * num / np.where(ok, den, 1.0), 0.0)
    return x1 - np.clip(step, x1 - x2, x1 - x0)


@dataclass(frozen=True)
class NoiseCurves:
    """Σ residual² (N²·m²) on a grid of h (m) of one recording's smooth part (``base``, per model) and its
    replicates (``reps``, (n_rep, K))."""

    grid: np.ndarray
    base: dict
    reps: dict


def noise_curves(df: pd.DataFrame, p: Params, smoothing: Smoothing, grid: np.ndarray, h_ref: dict,
                 residual_poly, n_rep: int = N_REPLICATES, seed: int = 0, **kin_kw) -> NoiseCurves:
    """The RMSE(h) curves of ``n_rep`` replicates of a validated recording with fresh noise (seeded).

    ``grid``: h (m, :func:`replicate_grid`); ``h_ref``: per model the recording's own ĥ (m);
    ``residual_poly``: :func:`euc_sim.identification.h_fit.residual_poly` (passed in: no
    import cycle); ``**kin_kw``: passed to :func:`euc_sim.identification.processing.kinematics`.
    """
    if int(n_rep) != n_rep or n_rep < 0:
        raise InputError(f"n_rep must be a non-negative integer, got {n_rep!r}")
    models = tuple(h_ref)
    t = df["t"].to_numpy(dtype=float)
    dt = sample_period(t)
    cols = [c for c in NOISY_COLUMNS if c in df.columns]
    smooth, sigma = {}, {}
    for c in cols:
        smooth[c], sigma[c] = split_noise(df[c].to_numpy(dtype=float), dt)

    def curves(frame):
        kin = kinematics(frame, p, smoothing, **kin_kw)
        return {m: sum_squares_near(residual_poly(kin, p, m), grid, h_ref[m]) for m in models}

    base = curves(df.assign(**smooth))
    rng = np.random.default_rng([int(seed), 22])
    reps = {m: np.empty((int(n_rep), len(grid))) for m in models}
    if _state_level(df, kin_kw):               # x, γ, φ as recorded: all replicates at once
        for j0 in range(0, int(n_rep), _CHUNK):
            b = min(_CHUNK, int(n_rep) - j0)
            Q = np.stack([smooth[c][None, :] + rng.normal(0.0, sigma[c], (b, len(t)))
                          for c in ("x", "gamma", "phi")], axis=-1)
            q, qd, qdd = savgol_derivatives(Q, dt, smoothing.samples(dt), smoothing.order, axis=1)
            kin = Kinematics(t=t, q=q, qd=qd, qdd=qdd, extra={}, smoothing=smoothing)
            for m in models:
                reps[m][j0:j0 + b] = sum_squares_near(residual_poly(kin, p, m), grid, h_ref[m])
    else:                                       # motion-capture columns: Section 2 per replicate
        for j in range(int(n_rep)):
            noisy = {c: smooth[c] + rng.normal(0.0, sigma[c], len(t)) for c in cols if sigma[c] > 0}
            for m, ss in curves(df.assign(**noisy)).items():
                reps[m][j] = ss
    return NoiseCurves(grid=np.asarray(grid, dtype=float), base=base, reps=reps)


@dataclass(frozen=True)
class NoiseSpread:
    """What fresh measurement noise does to ĥ, one model: ``h_smooth`` (the smooth parts' h, m) and ``boot`` (each
    replicate's, m)."""

    h_smooth: float
    boot: np.ndarray

    @property
    def bias(self) -> float:
        """Mean replicate minus h of the smooth parts: the errors-in-variables bias of ĥ, m."""
        return float(np.mean(self.boot) - self.h_smooth) if self.boot.size else math.nan

    @property
    def sd(self) -> float:
        """Spread of ĥ due to the measurement noise, m."""
        return float(np.std(self.boot, ddof=1)) if self.boot.size > 1 else math.nan


def noise_spread(curves: list[NoiseCurves], model: str) -> NoiseSpread:
    """Pool the replicate curves of several recordings (replicate j with j) and minimise each, one model
    (ValueError when grids or counts differ)."""
    if not curves:
        raise ValueError("no recordings to pool")
    grid = curves[0].grid
    for c in curves[1:]:
        if c.grid.shape != grid.shape or not np.allclose(c.grid, grid):
            raise ValueError("noise curves of pooled recordings must share one grid of h")
        if c.reps[model].shape != curves[0].reps[model].shape:
            raise ValueError("noise curves of pooled recordings must have as many replicates")
    base = sum(c.base[model] for c in curves)
    reps = sum(c.reps[model] for c in curves)
    h0 = float(grid_minimum(grid, base)[0])
    boot = grid_minimum(grid, reps) if reps.shape[0] else np.array([])
    return NoiseSpread(h_smooth=h0, boot=np.asarray(boot, dtype=float))
