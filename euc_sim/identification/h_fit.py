"""h from a recording: the minimiser of RMSE(M_d,1 − M_d,2) (paper Section 4).

M_d,1 (eq. 9) is affine in h and M_d,1 − M_d,2 = P(h)/D(h), P quadratic and
D = m_11 R + m_21 + m_31 affine in h, so RMSE(h) on a whole grid is a few array
operations (:func:`residual_poly`).  P's coefficients are term-filtered (the consistent
filter); D varies by < 1 % along a ride.  See docs/identification.md and docs/coverage.md.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from euc_sim.errors import InputError
from euc_sim.model import analytic
from euc_sim.model.parameters import Params
from euc_sim.identification.processing import DEFAULT_SMOOTHING, Kinematics, Smoothing, kinematics, term_filter
from euc_sim.identification.recordings import params_from_meta, read_recording
from euc_sim.identification.torques import MODELS, model_functions
from euc_sim.stats import basic_interval, moving_block_starts


#: Values of h (m) at which the torques are evaluated to recover their coefficients in h.
_H_NODES = np.array([0.5, 1.0, 1.5])


@dataclass(frozen=True)
class ResidualPoly:
    """M_d,1 − M_d,2 of one recording as P(h)/D(h), filtered, interior samples only.

    Attributes
    ----------
    model : str
    P : ndarray, shape (3, N)
        Coefficients of h⁰, h¹, h² of (M_d,1 − M_d,2)·D, N·m·kg·m per power of h.
    D : ndarray, shape (2, N)
        Coefficients of h⁰, h¹ of D, kg·m.
    t : ndarray, shape (N,)
    """

    model: str
    P: np.ndarray
    D: np.ndarray
    t: np.ndarray

    def residual(self, h) -> np.ndarray:
        """M_d,1 − M_d,2 (filtered) for scalar h → (N,) or h of shape (K,) → (K, N), N·m."""
        h = np.asarray(h, dtype=float)[..., None]
        return (self.P[0] + h * (self.P[1] + h * self.P[2])) / (self.D[0] + h * self.D[1])

    def sum_squares(self, h) -> np.ndarray:
        """Σ_t residual², N²·m², for scalar or (K,) h."""
        return np.sum(self.residual(h) ** 2, axis=-1)

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.P.shape[1]


def _lagrange_coefficients(nodes: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Coefficients (c0, c1, c2, ...) of the polynomial through (nodes, values), per column."""
    V = np.vander(nodes, len(nodes), increasing=True)
    return np.linalg.solve(V, values.reshape(len(nodes), -1)).reshape(values.shape)


def residual_poly(kin: Kinematics, p: Params, model: str = "3dof") -> ResidualPoly:
    """The exact polynomial form in h of M_d,1 − M_d,2 (eqs. 9, 10 or 13) for one recording.

    Parameters
    ----------
    kin : Kinematics
    p : Params
        Every parameter but h is used.
    model : {"3dof", "2dof"}

    Returns
    -------
    ResidualPoly
    """
    P, D = residual_coefficients(kin, p, model)
    P = term_filter(P, kin.smoothing.sigma_samples(kin.dt), axis=-1)
    sl = kin.interior
    return ResidualPoly(model=model, P=P[..., sl], D=D[..., sl], t=kin.t[sl])


def residual_coefficients(kin: Kinematics, p: Params, model: str = "3dof") -> tuple[np.ndarray, np.ndarray]:
    """Unfiltered coefficients in h of M_d,1 − M_d,2 = P(h)/D(h) at every sample: P (3, N), N·m·kg·m per power of
    h, and D (2, N), kg·m (:func:`residual_poly`)."""
    md1, md2, mass_params = model_functions(model)
    num, den = [], []
    for h in _H_NODES:
        ph = p.replace(h=float(h))
        M = analytic.mass_matrix(mass_params(ph), kin.q)
        D = M[..., 0, 0] * ph.R + M[..., 1, 0] + M[..., 2, 0]
        num.append((md1(ph, kin.q, kin.qd, kin.qdd) - md2(ph, kin.q, kin.qd, kin.qdd)) * D)
        den.append(D)
    D1 = (den[1] - den[0]) / (_H_NODES[1] - _H_NODES[0])
    return _lagrange_coefficients(_H_NODES, np.array(num)), np.array([den[0] - _H_NODES[0] * D1, D1])


# --- identifying h ---------------------------------------------------------------------------
@dataclass
class HFit:
    """h identified from one or several recordings, one model.

    Attributes
    ----------
    model : str
    h : float
        Minimiser of RMSE(M_d,1 − M_d,2), m.
    rmse : float
        RMSE at the minimum, N·m.
    h_ci95 : tuple of float
        95 % interval (basic bootstrap, widened by :func:`with_noise`), m, within the bounds.
    identifiable : bool
        The verdict (:func:`_verdict`).
    flatness : float
        The rise RMSE(h ± 0.1 m)/RMSE(h) − 1, the smaller side.
    h_grid, rmse_grid : ndarray
        The RMSE(h) curve, m and N·m.
    boot : ndarray
        Bootstrap minimisers, m.
    n_samples : int
    reason : str
        One sentence on the verdict.
    h_ci95_block : tuple of float
        The moving-block bootstrap's interval alone, m.
    noise_sd, noise_bias : float
        Spread and bias of ĥ due to the measurement noise, m (NaN until :func:`with_noise`).
    """

    model: str
    h: float
    rmse: float
    h_ci95: tuple
    identifiable: bool
    flatness: float
    h_grid: np.ndarray
    rmse_grid: np.ndarray
    boot: np.ndarray = field(repr=False)
    n_samples: int = 0
    reason: str = ""
    h_ci95_block: tuple = (math.nan, math.nan)
    noise_sd: float = math.nan
    noise_bias: float = math.nan

    def at_bound(self) -> list[str]:
        """The fitted quantities within two grid steps of the search bounds: ``"h"``, ``"h_ci95"``."""
        lo, hi = float(self.h_grid[0]), float(self.h_grid[-1])
        margin = 2 * float(self.h_grid[1] - self.h_grid[0])
        out = ["h"] if not (lo + margin <= self.h <= hi - margin) else []
        ci = [c for c in self.h_ci95 if math.isfinite(c)]
        if ci and (min(ci) < lo + margin or max(ci) > hi - margin):
            out.append("h_ci95")
        return out

    def as_json(self) -> dict:
        """The CONTRACT form (``h, h_ci95, rmse, identifiable``) plus extras and the RMSE(h) ``curve``."""
        return {"h": self.h, "h_ci95": list(self.h_ci95), "rmse": self.rmse,
                "identifiable": bool(self.identifiable), "flatness": self.flatness,
                "n_samples": self.n_samples, "reason": self.reason,
                "h_ci95_block": list(self.h_ci95_block), "noise_sd": self.noise_sd,
                "noise_bias": self.noise_bias, "at_bound": self.at_bound(),
                "curve": {"h": self.h_grid, "rmse": self.rmse_grid}}


def _parabolic_min(grid: np.ndarray, J: np.ndarray) -> np.ndarray:
    """Grid minimiser along the last axis refined by a parabola through 3 points."""
    k = np.clip(np.argmin(J, axis=-1), 1, J.shape[-1] - 2)
    j0, j1, j2 = (np.take_along_axis(J, np.expand_dims(k + d, -1), -1)[..., 0] for d in (-1, 0, 1))
    den = j0 - 2 * j1 + j2
    step = grid[1] - grid[0]
    off = np.where(den > 0, 0.5 * (j0 - j2) / np.where(den > 0, den, 1.0), 0.0)
    return grid[k] + np.clip(off, -1.0, 1.0) * step


#: Moving-block bootstrap block, s (docs/coverage.md#what-the-interval-is-now).
BOOTSTRAP_BLOCK = 1.0


def _block_sums(x: np.ndarray, L: int, starts: np.ndarray) -> np.ndarray:
    """Sums of x (K, N) over the drawn blocks [s, s + L) of each replicate → (n_boot, K)."""
    cs = np.concatenate([np.zeros((x.shape[0], 1)), np.cumsum(x, axis=1)], axis=1)
    return (cs[:, starts + L] - cs[:, starts]).sum(axis=2).T


#: Smallest :attr:`HFit.flatness` called identifiable (docs/identification.md).
MIN_RISE = 0.75
#: Widest 95 % interval still called identifiable, m (braking rides: 0.007-0.054 m).
MAX_CI_WIDTH = 0.15
#: Fewest bootstrap replicates that give a 95 % interval (and a verdict of identifiable).
MIN_BOOT = 50
#: Fewest bootstrap blocks (over all recordings) for the interval to mean anything.
MIN_BLOCKS = 8
#: Spacing of the grid of h on which RMSE(h) is kept, m.
GRID_STEP = 0.02


def identify_h(polys: list[ResidualPoly], bounds=(0.1, 1.5), n_boot: int = 400, block: float = BOOTSTRAP_BLOCK,
               seed: int = 0) -> HFit:
    """Minimise the pooled RMSE(M_d,1 − M_d,2) over h in ``bounds``.

    A grid search (:data:`GRID_STEP`) keeps the whole curve and a bounded Brent search refines
    its minimum; the 95 % interval is the basic interval of a moving-block bootstrap over time.

    Parameters
    ----------
    polys : list of ResidualPoly
        One per recording, same model.
    bounds : (float, float)
        Search interval for h, m.
    n_boot : int
        Bootstrap replicates (fewer than :data:`MIN_BOOT`: never identifiable).
    block : float
        Block length, s.
    seed : int

    Returns
    -------
    HFit
    """
    lo, hi = map(float, bounds)
    if not (0 < lo < hi):
        raise InputError(f"h bounds must satisfy 0 < lo < hi, got {bounds!r}")
    if not polys:
        raise ValueError("no recordings to identify h from")
    grid = np.linspace(lo, hi, int(round((hi - lo) / GRID_STEP)) + 1)
    n_tot = sum(rp.n for rp in polys)
    J, boot_tot, draws = _curve_and_draws(polys, grid, n_boot, block, seed)
    h_opt, rmse = _refined_minimum(polys, grid, J)
    boot, ci = np.array([]), (math.nan, math.nan)
    if n_boot > 0:
        boot, ci = _bootstrap_interval(polys, grid, boot_tot, draws, h_opt)
    curve = np.sqrt(J)
    side = [np.interp(h_opt + d, grid, curve) for d in (-0.1, 0.1) if lo <= h_opt + d <= hi]
    flatness = float(min(side) / rmse - 1.0) if side and rmse > 0 else math.inf
    blocks = sum(int(math.ceil(rp.n / L)) for rp, (L, _) in zip(polys, draws))
    ok, why = _verdict(h_opt, ci, flatness, (lo, hi), 2 * GRID_STEP, n_boot, block, blocks)
    return HFit(model=polys[0].model, h=h_opt, rmse=rmse, h_ci95=ci, identifiable=ok, flatness=flatness,
                h_grid=grid, rmse_grid=curve, boot=boot, n_samples=n_tot, reason=why, h_ci95_block=ci)


def with_noise(fit: HFit, spread, n_boot: int, block: float, blocks: int) -> HFit:
    """``fit`` with its interval widened by what the measurement noise does to ĥ.

    The interval becomes the union of the block bootstrap's and ĥ − b ± 1.96 s, s and b
    the spread and bias of ĥ under fresh noise (:class:`~euc_sim.identification.noise_bootstrap.NoiseSpread`);
    the verdict is re-drawn (docs/coverage.md).  ``n_boot, block, blocks``: the block
    bootstrap's replicates, block (s) and block count, for the verdict.
    """
    sd, b = spread.sd, spread.bias
    if not (math.isfinite(sd) and math.isfinite(b)):
        return fit
    lo, hi = float(fit.h_grid[0]), float(fit.h_grid[-1])
    c = fit.h - b
    blo, bhi = fit.h_ci95_block
    ci = (max(lo, float(np.fmin(blo, c - 1.96 * sd))), min(hi, float(np.fmax(bhi, c + 1.96 * sd))))
    ok, why = _reverdict(fit, ci, n_boot, block, blocks)
    return dataclasses.replace(fit, h_ci95=ci, identifiable=ok, reason=why, noise_sd=sd, noise_bias=b)


#: The reduced model whose block bootstrap borrows the full model's replicates (:func:`with_full_block`).
REDUCED, FULL = "2dof", "3dof"


def with_full_block(reduced: HFit, full: HFit, n_boot: int, block: float, blocks: int) -> HFit:
    """The reduced model's fit with the full model's block-bootstrap replicates.

    The replicates become ĥ̄ + (ĥ* − ĥ), ĥ* the full model's replicates on the same draws,
    and the verdict is re-drawn: the reduced model's own bootstrap would resample the
    reduction's misfit as noise (docs/coverage.md#why-the-reduced-model-over-covered-tuning-seeds-700000-and-0).
    Returns ``reduced`` itself when ``full`` has no replicates.
    """
    if full.boot.size == 0:
        return reduced
    boot = reduced.h + (np.asarray(full.boot, dtype=float) - full.h)
    ci = _basic_interval(boot, reduced.h, float(reduced.h_grid[0]), float(reduced.h_grid[-1]))
    ok, why = _reverdict(reduced, ci, n_boot, block, blocks)
    return dataclasses.replace(reduced, h_ci95=ci, h_ci95_block=ci, boot=boot, identifiable=ok, reason=why)


def _curve_and_draws(polys: list[ResidualPoly], grid: np.ndarray, n_boot: int, block: float,
                     seed: int) -> tuple[np.ndarray, np.ndarray, list]:
    """Pooled mean square residual ``J`` on the grid, N·m², the replicates' sums, and per recording ``(L, starts)``."""
    n_tot = sum(rp.n for rp in polys)
    rng = np.random.default_rng(seed)
    draws = []
    ss = np.zeros(len(grid))
    boot_tot = np.zeros((n_boot, len(grid)))
    for rp in polys:                               # one recording at a time: (K, N_i) arrays
        x = rp.residual(grid) ** 2
        ss += x.sum(axis=1)
        if n_boot > 0:
            dt = float(rp.t[1] - rp.t[0]) if rp.n > 1 else 1.0
            L = int(min(max(1, round(block / dt)), rp.n))
            starts = moving_block_starts(rp.n, L, n_boot, rng)
            draws.append((L, starts))
            boot_tot += _block_sums(x, L, starts)
    return ss / n_tot, boot_tot, draws


def _refined_minimum(polys: list[ResidualPoly], grid: np.ndarray, J: np.ndarray) -> tuple[float, float]:
    """The grid minimum refined by a bounded Brent search in its bracket: (h, m; RMSE, N·m)."""
    n_tot = sum(rp.n for rp in polys)
    k = int(np.argmin(J))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    f = lambda h: float(sum(rp.sum_squares(h) for rp in polys)) / n_tot      # noqa: E731
    from scipy.optimize import minimize_scalar

    res = minimize_scalar(f, bounds=(a, b), method="bounded", options={"xatol": 1e-10})
    h_opt = float(res.x) if res.fun <= J[k] else float(grid[k])
    return h_opt, math.sqrt(min(res.fun, J[k]))


def _bootstrap_interval(polys: list[ResidualPoly], grid: np.ndarray, boot_tot: np.ndarray, draws: list,
                        h_opt: float) -> tuple[np.ndarray, tuple[float, float]]:
    """The replicates' minimisers and the basic (reverse-percentile) 95 % interval, m."""
    lo, hi = float(grid[0]), float(grid[-1])
    n_boot = boot_tot.shape[0]
    boot = _parabolic_min(grid, boot_tot)
    # refine twice on finer grids spanning the replicates' minima (the same draws)
    step = grid[1] - grid[0]
    for _ in range(2):
        fine = np.linspace(max(lo, boot.min() - step), min(hi, boot.max() + step), 41)
        fine_tot = np.zeros((n_boot, len(fine)))
        for rp, (L, starts) in zip(polys, draws):
            fine_tot += _block_sums(rp.residual(fine) ** 2, L, starts)
        boot = _parabolic_min(fine, fine_tot)
        step = 2 * (fine[1] - fine[0])
    return boot, _basic_interval(boot, h_opt, lo, hi)


def _basic_interval(boot: np.ndarray, h: float, lo: float, hi: float) -> tuple[float, float]:
    """The basic (reverse-percentile) 95 % interval of ``boot`` about ``h``, within [lo, hi], m
    (docs/coverage.md#what-the-interval-is-now)."""
    b_lo, b_hi = basic_interval(boot, h)
    return float(max(lo, b_lo)), float(min(hi, b_hi))


def _reverdict(fit: HFit, ci: tuple[float, float], n_boot: int, block: float, blocks: int) -> tuple[bool, str]:
    """:func:`_verdict` of ``fit`` with another interval ``ci`` (m), on its own grid."""
    lo, hi = float(fit.h_grid[0]), float(fit.h_grid[-1])
    step = float(fit.h_grid[1] - fit.h_grid[0])
    return _verdict(fit.h, ci, fit.flatness, (lo, hi), 2 * step, n_boot, block, blocks)


def _verdict(h_opt: float, ci: tuple[float, float], flatness: float, bounds: tuple[float, float],
             margin: float, n_boot: int, block: float, blocks: int) -> tuple[bool, str]:
    """Identifiable or not, and why: an interior minimum, :data:`MIN_BOOT` replicates over :data:`MIN_BLOCKS`
    blocks, an interval clear of the bounds and at most :data:`MAX_CI_WIDTH` wide, a rise of :data:`MIN_RISE`."""
    lo, hi = bounds
    if h_opt < lo + margin or h_opt > hi - margin:
        return False, f"the minimum lies at the search bound ({h_opt:.3f} m in [{lo}, {hi}] m)"
    if n_boot < MIN_BOOT:
        return False, (f"{n_boot} bootstrap replicates are too few for a 95% interval "
                       f"(need at least {MIN_BOOT}); no verdict without one")
    if blocks < MIN_BLOCKS:
        return False, (f"the bootstrap block ({block:g} s) cuts the data into only {blocks} "
                       f"block(s) (need at least {MIN_BLOCKS}): the interval cannot be trusted")
    if ci[0] < lo + margin or ci[1] > hi - margin:
        return False, (f"the 95% interval [{ci[0]:.3f}, {ci[1]:.3f}] m reaches the search "
                       f"bound: the RMSE curve is flat")
    if ci[1] - ci[0] > MAX_CI_WIDTH:
        return False, (f"the 95% interval is {ci[1] - ci[0]:.3f} m wide (> {MAX_CI_WIDTH} m): "
                       f"the RMSE curve is too shallow")
    if flatness < MIN_RISE:
        return False, (f"the RMSE rises only {100 * flatness:.1f}% within ±0.1 m of the minimum "
                       f"(identifiable from {100 * MIN_RISE:.0f}%, as braking and accelerating "
                       f"rides): too shallow, the noise moves h")
    return True, (f"interior minimum, RMSE rises {100 * flatness:.1f}% within ±0.1 m "
                  f"(≥ {100 * MIN_RISE:.0f}%), 95% interval {ci[1] - ci[0]:.3f} m wide")


# --- recordings, end to end ------------------------------------------------------------------
@dataclass
class Recording:
    """A loaded recording: its data, metadata, parameters and kinematics."""

    name: str
    df: pd.DataFrame
    meta: dict
    params: Params
    kin: Kinematics
    #: how ``kin`` was made from ``df`` beyond the smoothing (``d_CE``, ``phi_from``, ``source``)
    kin_kw: dict = field(default_factory=dict)


def load(path, smoothing: Smoothing = DEFAULT_SMOOTHING, params: Params | None = None,
         d_CE: float | None = None, phi_from: str = "A", source: str = "auto") -> Recording:
    """Read, validate and differentiate one recording.

    Parameters
    ----------
    path : path
    smoothing : Smoothing
    params : Params, optional
        Overrides the sidecar's parameters.
    d_CE : float, optional
        C–E distance for motion-capture files, m (else the sidecar's ``"d_CE"``).
    phi_from : {"A", "C"}
        The exact rider pitch or eq. (3), motion-capture files only.
    source : {"auto", "state", "mocap"}
        See :func:`euc_sim.identification.processing.kinematics`.
    """
    df, meta = read_recording(path)
    p = params if params is not None else params_from_meta(meta, path)
    if d_CE is None and meta.get("d_CE") is not None:
        d_CE = float(meta["d_CE"])
    kin_kw = dict(d_CE=d_CE, phi_from=phi_from, source=source)
    kin = kinematics(df, p, smoothing, name=str(path), **kin_kw)
    return Recording(name=str(path), df=df, meta=meta, params=p, kin=kin, kin_kw=kin_kw)


def identify_recordings(recs: list[Recording], bounds=(0.1, 1.5), n_boot: int = 400,
                        block: float = BOOTSTRAP_BLOCK, seed: int = 0, n_noise: int | None = None) -> dict:
    """Per-recording and pooled h for both models.

    Intervals: :func:`with_full_block` for the reduced model, then :func:`with_noise` with
    ``n_noise`` noise replicates per recording (default ``noise_bootstrap.N_REPLICATES``; 0: none).

    Returns
    -------
    dict
        ``{"pooled": {model: HFit}, "per_recording": [{model: HFit}, ...]}``.
    """
    kw = dict(bounds=bounds, n_boot=n_boot, block=block)
    polys = [{m: residual_poly(r.kin, r.params, m) for m in MODELS} for r in recs]
    per = [{m: identify_h([pp[m]], seed=seed + i, **kw) for m in MODELS}
           for i, pp in enumerate(polys)]
    pooled = ({m: identify_h([pp[m] for pp in polys], seed=seed, **kw) for m in MODELS}
              if len(recs) > 1 else per[0])

    def blocks(rps):
        return sum(int(math.ceil(rp.n / max(1, round(block / float(rp.t[1] - rp.t[0]))))) for rp in rps)

    def borrow(fits, rps):                     # the reduced model's replicates: the full model's
        return {**fits, REDUCED: with_full_block(fits[REDUCED], fits[FULL], n_boot, block, blocks(rps))}

    per = [borrow(fits, [pp[REDUCED]]) for fits, pp in zip(per, polys)]
    pooled = borrow(pooled, [pp[REDUCED] for pp in polys]) if len(recs) > 1 else per[0]
    from euc_sim.identification import noise_bootstrap as nb  # deferred: loads scipy.signal (1.1 s)

    n_noise = nb.N_REPLICATES if n_noise is None else int(n_noise)
    if n_noise > 0:
        grid = nb.replicate_grid(bounds)
        curves = [nb.noise_curves(r.df, r.params, r.kin.smoothing, grid, {m: f.h for m, f in fits.items()},
                                  residual_poly, n_noise, seed=seed + i, **r.kin_kw)
                  for i, (r, fits) in enumerate(zip(recs, per))]

        def widen(fit, cs, rps):
            return with_noise(fit, nb.noise_spread(cs, fit.model), n_boot, block, blocks(rps))

        per = [{m: widen(f, [c], [pp[m]]) for m, f in fits.items()}
               for fits, c, pp in zip(per, curves, polys)]
        pooled = ({m: widen(f, curves, [pp[m] for pp in polys]) for m, f in pooled.items()}
                  if len(recs) > 1 else per[0])
    return {"pooled": pooled, "per_recording": per}
