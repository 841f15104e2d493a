"""Least-squares fit of a ride's balance with wild block bootstrap intervals.

:func:`fit_balance` fits a :class:`~euc_sim.rides.balance.design.Design` (scipy's
bounded ``least_squares``: the model is linear in every term but the current lag);
:func:`plausibility` turns a fit into physical estimates with units and flags.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from euc_sim.errors import InputError
from euc_sim.rides.balance.design import BOUNDS, CANDIDATES, NOMINAL, PLAUSIBLE, Design, on_bound
from euc_sim.rides.grids.power import RHO_AIR
from euc_sim.stats import percentile_interval, wild_block_signs

__all__ = ["BalanceFit", "fit_balance", "block_rows", "plausibility", "MIN_BLOCKS", "FEW_BLOCKS"]

#: Fewest bootstrap blocks a fit with intervals accepts: with one block every
#: replicate resamples the whole residual in order, and the interval has zero width.
MIN_BLOCKS = 2
#: Below this many blocks the intervals are rough (reported as a note).
FEW_BLOCKS = 5

#: Start values of the least-squares fit (its bounds are :data:`BOUNDS`).
_START = {"copper_loss": 0.0, "rolling_resistance": 0.0,
          "aerodynamic_drag": 0.0, "road_slope": 0.0, "road_slope_gps": 1.0,
          "drivetrain_idle_loss": 0.0, "current_lag": 0.0}


@dataclass(frozen=True)
class BalanceFit:
    """A least-squares fit of a :class:`Design`, with block-bootstrap intervals.

    Attributes
    ----------
    names : tuple of str
        Fitted parameters (keys of :data:`CANDIDATES`).
    estimate : dict
        Value of each, in the unit of :data:`CANDIDATES`.
    ci95 : dict
        95 % percentile intervals from a wild block bootstrap (:func:`_bootstrap`).
    se_naive : dict
        Standard errors from the Jacobian, assuming independent residuals (they
        are not: shown for comparison only).
    rmse : float
        In-sample RMS weighted residual, W or N·m.
    n : int
        Rows used.
    n_boot, block_s, seed :
        Bootstrap settings.
    unit : str
    boot_corr : dict
        Correlation of the bootstrap replicates of each pair of parameters,
        ``{(a, b): r}``; |r| near 1 means this ride cannot tell a from b.
    """

    names: tuple[str, ...]
    estimate: Mapping[str, float]
    ci95: Mapping[str, tuple[float, float]]
    se_naive: Mapping[str, float]
    rmse: float
    n: int
    n_boot: int
    block_s: float
    seed: int
    unit: str = "W"
    boot_corr: Mapping[tuple[str, str], float] = None

    def confounded(self, name: str, threshold: float = 0.8) -> tuple[str, ...]:
        """Parameters whose bootstrap replicates correlate with ``name``'s beyond ±threshold."""
        if not self.boot_corr:
            return ()
        return tuple(b for (a, b), r in self.boot_corr.items()
                     if a == name and b != name and abs(r) >= threshold)

    def rmse_on(self, design: Design) -> float:
        """RMS weighted residual of this fit on another design, W or N·m."""
        r = design.residual(self.estimate)
        return float(np.sqrt(np.mean(r ** 2)))


def _scale(names: Sequence[str]) -> np.ndarray:
    """Typical size of each parameter: ``least_squares``'s ``x_scale`` and the step test."""
    return np.array([{"drivetrain_idle_loss": 10.0, "aerodynamic_drag": 0.1,
                      "rolling_resistance": 0.01, "road_slope": 0.01,
                      "copper_loss": 0.005}.get(n, 0.1) for n in names])


def _bounds(names: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    lo = np.array([BOUNDS.get(n, (-np.inf, np.inf))[0] for n in names])
    hi = np.array([BOUNDS.get(n, (-np.inf, np.inf))[1] for n in names])
    return lo, hi


def _solve(design: Design, names: Sequence[str], x0: np.ndarray, P: np.ndarray | None = None):
    """scipy's bounded ``least_squares`` (trf) with the design's analytic Jacobian."""
    from types import SimpleNamespace

    from scipy.optimize import least_squares

    if not len(names):                      # the inertia-only model: nothing to fit
        r = design.residual({}, P)
        return SimpleNamespace(x=np.empty(0), fun=r, jac=np.empty((r.size, 0)))
    lo, hi = _bounds(names)
    # start inside the box: from a bound, trf's scaling can take steps too small to leave it
    inset = np.where(np.isfinite(hi - lo), 1e-3 * (hi - lo), 1e-9)
    res = least_squares(lambda th: design.residual(dict(zip(names, th)), P),
                        np.clip(x0, lo + inset, hi - inset),
                        jac=lambda th: design.jacobian_many(names, th[:, None])[:, :, 0],
                        bounds=(lo, hi), x_scale=_scale(names), method="trf")
    res.x = _snap_to_bounds(res.x, lo, hi, _scale(names))
    return res


#: A parameter within this fraction of its typical size from a bound sits on it.
_BOUND_SNAP = 1e-6


def _snap_to_bounds(x: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                    scale: np.ndarray) -> np.ndarray:
    """``x`` with values within ``_BOUND_SNAP``·scale of a bound set exactly on it.

    scipy's trf keeps iterates strictly inside the box, so a parameter whose
    optimum is a bound comes back a rounding error (1e-30) away from it; with
    the value on the bound, the Gauss-Newton replicates hold it there and the
    page can say that it sits on its bound.  Returns a new array.
    """
    x = np.array(x, dtype=float)
    x = np.where(np.abs(x - lo) <= _BOUND_SNAP * scale, lo, x)
    return np.where(np.abs(hi - x) <= _BOUND_SNAP * scale, hi, x)


def block_rows(design: Design, block_s: float = 10.0, check: bool = True) -> int:
    """Rows per bootstrap block of ``block_s`` s on ``design``'s grid.

    Raises
    ------
    ValueError
        (with ``check``) naming the ride, when its rows in use hold fewer than
        :data:`MIN_BLOCKS` blocks: too little data for an interval.
    """
    if not (math.isfinite(block_s) and block_s > 0):
        raise InputError(f"block_s must be a positive number of seconds, got {block_s!r}")
    n = len(design.P)
    dt = float(np.median(np.diff(design.t))) if n > 1 else 0.1
    L = max(1, int(round(block_s / dt))) if dt > 0 else 1
    if check and n < MIN_BLOCKS * L:
        raise InputError(f"{design.path}: {n} usable rows ({n * dt:.1f} s of ride) to fit on, too "
                         f"few for a 95 % interval: the block bootstrap needs at least "
                         f"{MIN_BLOCKS} blocks of {block_s:g} s ({MIN_BLOCKS * L} rows, "
                         f"{MIN_BLOCKS * block_s:g} s after gaps and filter ends)")
    return L


def _bootstrap(design: Design, names: Sequence[str], theta: np.ndarray, fitted_P: np.ndarray,
               e_P: np.ndarray, L: int, n_boot: int, seed: int):
    """Wild block bootstrap: 2.5/97.5 percentiles and replicate correlations.

    Each replicate keeps every residual at its own row and flips the sign of
    whole blocks of ``L`` rows at random (Rademacher weights per block): the
    autocorrelation within a block is kept, and so is the residual's
    dependence on the regime (an inertia-only fit leaves large residuals on
    the regenerating rows, which a moving-block bootstrap would carry onto the
    motoring rows, biasing η_m so far that its estimate could fall outside its
    own interval).  The replicates then centre on the estimate, and a
    parameter on its bound stays on or inside it, so the percentiles respect
    the bound.

    The replicates' fits are solved together (:func:`_batch_solve`, Gauss-Newton
    from the fit's estimate); one that leaves the bounds or does not converge is
    refitted alone by :func:`_solve`, as every replicate once was.
    """
    n = len(e_P)
    if not len(names):
        return np.empty(0), np.empty(0), {}
    rng = np.random.default_rng(seed)
    targets = fitted_P[:, None] + e_P[:, None] * wild_block_signs(n, L, n_boot, rng)
    boots = np.empty((n_boot, len(names)))
    for c in range(0, n_boot, _CHUNK):
        sl = slice(c, min(c + _CHUNK, n_boot))
        boots[sl], done = _batch_solve(design, names, theta, targets[:, sl])
        for i in np.flatnonzero(~done) + c:
            boots[i] = _solve(design, names, theta, P=targets[:, i]).x
    corr = {}
    if not n_boot:
        nan = np.full(len(names), np.nan)
        return nan, nan, corr
    lo, hi = percentile_interval(boots)
    if n_boot > 2:
        with np.errstate(invalid="ignore", divide="ignore"):
            C = np.corrcoef(boots, rowvar=False)
        corr = {(a, b): float(C[i, j]) for i, a in enumerate(names)
                for j, b in enumerate(names) if i != j and np.isfinite(C[i, j])}
    return lo, hi, corr


#: Bootstrap replicates solved together (bounds the memory: rows × parameters × chunk).
_CHUNK = 25
#: Gauss-Newton stops when every step is below this fraction of the parameter's size.
_STEP_TOL = 1e-10
#: ... or when an iteration lowers the cost by less than this fraction of it.
_COST_TOL = 1e-13
_MAX_ITER = 50


def _gauss_newton_step(J: np.ndarray, r: np.ndarray, Theta: np.ndarray, lo: np.ndarray,
                       hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per replicate, the step minimising |r + J·δ|² with the bounds' active set held.

    A parameter on its bound whose cost gradient points out of the box stays
    there (δ = 0); the others take the Gauss-Newton step, from the normal
    equations scaled by their diagonal.

    Returns ``(delta, ok)``: parameters × B, and False where the scaled normal
    matrix is nearly singular (those replicates are left to :func:`_solve`).
    """
    Jb = np.ascontiguousarray(J.transpose(2, 1, 0))     # B × parameters × rows
    A = Jb @ Jb.transpose(0, 2, 1)
    g = (Jb @ r.T[:, :, None])[:, :, 0]                 # ∇(½|r|²)
    fixed = (((Theta <= lo[:, None]) & (g.T > 0)) | ((Theta >= hi[:, None]) & (g.T < 0))).T
    A = np.where(fixed[:, :, None] | fixed[:, None, :], np.eye(A.shape[1]), A)
    g = np.where(fixed, 0.0, g)
    d = np.sqrt(np.einsum("bii->bi", A))
    ok = (d > 0).all(axis=1)
    d = np.where(d > 0, d, 1.0)
    A_s = A / (d[:, :, None] * d[:, None, :])
    ev = np.linalg.eigvalsh(A_s)
    ok &= ev[:, 0] > 1e-12 * ev[:, -1]
    A_s[~ok] = np.eye(A.shape[1])
    delta = -np.linalg.solve(A_s, (g / d)[:, :, None])[:, :, 0] / d
    return delta.T, ok


def _batch_solve(design: Design, names: Sequence[str], theta: np.ndarray,
                 targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least squares for many targets at once: Gauss-Newton from ``theta``, all together.

    Each replicate takes the Gauss-Newton step, halved until its cost does not
    rise (:func:`_line_search`).  It is done when the full step is below
    ``_STEP_TOL`` of every parameter's size, or when the cost no longer falls by
    more than ``_COST_TOL`` of itself (``least_squares`` stops at 1e-8: its
    ``ftol``); near a switch between motoring and regenerating the cost has a
    kink, where that second test ends the iteration.  Bounds: a parameter on its
    bound with the cost falling outwards is held there, and steps are projected
    into the box (:func:`_gauss_newton_step`).

    Returns ``(Theta, done)``: B × parameters, and True where the iteration
    converged; the others (a nearly singular Jacobian, no convergence in
    ``_MAX_ITER`` steps) are for :func:`_solve`.
    """
    names = list(names)
    B = targets.shape[1]
    lo, hi = _bounds(names)
    size = np.abs(theta) + _scale(names)
    Theta = np.repeat(np.asarray(theta, float)[:, None], B, axis=1)
    D = design.demand(names, Theta)
    r = design.weight[:, None] * (targets - design.predict_many(names, Theta, D))
    cost = np.einsum("nb,nb->b", r, r)
    active, done = np.ones(B, bool), np.zeros(B, bool)
    for _ in range(_MAX_ITER):
        idx = np.flatnonzero(active)
        if not idx.size:
            break
        delta, ok = _gauss_newton_step(design.jacobian_many(names, Theta[:, idx], D[:, idx]),
                                       r[:, idx], Theta[:, idx], lo, hi)
        small = (np.abs(delta) <= _STEP_TOL * size[:, None]).all(axis=0)
        Theta_t, D_t, r_t, cost_t, fell = _line_search(design, names, Theta[:, idx], delta,
                                                       targets[:, idx], cost[idx])
        flat = ~fell | (cost[idx] - cost_t <= _COST_TOL * cost[idx])
        keep = idx[ok & fell]
        Theta[:, keep], D[:, keep] = Theta_t[:, ok & fell], D_t[:, ok & fell]
        r[:, keep], cost[keep] = r_t[:, ok & fell], cost_t[ok & fell]
        done[idx[ok & (small | flat)]] = True
        active[idx[~ok | small | flat]] = False
    return Theta.T, done


def _line_search(design: Design, names: list[str], Theta: np.ndarray, delta: np.ndarray,
                 targets: np.ndarray, cost: np.ndarray, halvings: int = 20):
    """The step Theta + t·delta (projected on the bounds), t = 1, ½, ¼, …: the largest t
    whose cost is no higher.

    Returns ``(Theta_t, D_t, r_t, cost_t, fell)``, one column per replicate;
    ``fell`` is False where no such t was found (the columns are then unset).
    """
    B = Theta.shape[1]
    lo, hi = _bounds(names)
    out = [np.empty_like(Theta), None, np.empty_like(targets), np.full(B, np.inf),
           np.zeros(B, bool)]
    todo = np.arange(B)
    t = 1.0
    for _ in range(halvings):
        trial = np.clip(Theta[:, todo] + t * delta[:, todo], lo[:, None], hi[:, None])
        D_t = design.demand(names, trial)
        r_t = design.weight[:, None] * (targets[:, todo] - design.predict_many(names, trial, D_t))
        c_t = np.einsum("nb,nb->b", r_t, r_t)
        good = np.isfinite(c_t) & (c_t <= cost[todo])
        if out[1] is None:
            out[1] = np.empty((D_t.shape[0], B))
        j = todo[good]
        out[0][:, j], out[1][:, j], out[2][:, j] = trial[:, good], D_t[:, good], r_t[:, good]
        out[3][j], out[4][j] = c_t[good], True
        todo = todo[~good]
        if not todo.size:
            break
        t /= 2
    return tuple(out)


def fit_balance(design: Design, names: Sequence[str] | None = None, n_boot: int = 200,
                block_s: float = 10.0, seed: int = 0) -> BalanceFit:
    """Least squares (scipy ``least_squares``) with wild block bootstrap 95 % intervals.

    Residuals of a ride are autocorrelated (the filter; an unknown, varying road
    grade; the rider's lean, which the motor must also drive), so the bootstrap
    flips the sign of contiguous blocks of ``block_s`` seconds of residuals, each
    left at its own row, adds them to the fitted power and refits; the intervals
    are the 2.5 and 97.5 percentiles.
    Draws use ``numpy.random.default_rng(seed)``.

    Parameters
    ----------
    design : Design
    names : sequence of str, optional
        Parameters to fit (default: all of ``design.candidates``); none: the
        inertia-only model, nothing fitted.
    n_boot : int
        Bootstrap replicates (0: no intervals, NaN).
    block_s : float
        Block length, s.
    seed : int

    Returns
    -------
    BalanceFit

    Raises
    ------
    ValueError
        naming the ride, when it has too few rows for the parameters, or (with
        ``n_boot`` > 0) fewer than :data:`MIN_BLOCKS` blocks: with one block every
        replicate is the fit itself and the interval would have zero width.
    """
    names = list(names) if names is not None else list(design.candidates)
    for n in NOMINAL:
        if n not in names:
            names.insert(NOMINAL.index(n), n)
    bad = [n for n in names if n not in design.candidates]
    if bad:
        raise InputError(f"parameter {bad[0]!r} is not available on {design.path or 'this ride'} "
                         f"(available: {', '.join(design.candidates)})")
    n = len(design.P)
    if n <= len(names) + 2:
        raise InputError(f"{design.path}: {n} usable rows, too few for {len(names)} parameters")
    L = block_rows(design, block_s, check=n_boot > 0)
    x0 = np.array([_START[k] for k in names])
    res = _solve(design, names, x0)
    theta = res.x
    est = dict(zip(names, map(float, theta)))
    e = res.fun
    fitted_P = design.predict(est)
    # Unweighted residuals in P units are what gets resampled.
    e_P = design.P - fitted_P
    J = res.jac
    dof = max(n - len(names), 1)
    try:
        cov = (e @ e) / dof * np.linalg.pinv(J.T @ J)
        se = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        se = np.full(len(names), np.nan)
    lo, hi, corr = _bootstrap(design, names, theta, fitted_P, e_P, L, n_boot, seed)
    # a bounded estimate's replicates can pile up on one side of it (on or near its bound):
    # the interval reaches out to the estimate, widened, never narrowed
    lo, hi = np.fmin(lo, theta), np.fmax(hi, theta)
    return BalanceFit(names=tuple(names), estimate=est,
                      ci95={k: (float(a), float(b)) for k, a, b in zip(names, lo, hi)},
                      se_naive=dict(zip(names, map(float, se))),
                      rmse=float(np.sqrt(np.mean(e ** 2))), n=n, n_boot=n_boot,
                      block_s=block_s, seed=seed, unit=design.unit, boot_corr=corr)


def plausibility(fit: BalanceFit) -> dict[str, dict]:
    """Physical estimates of a fit, with units, intervals and plausibility flags.

    Adds the drag area C_dA = 2k/ρ (ρ = 1.2 kg/m³) and the road angle
    α = arcsin(sin α) where they apply.

    Returns
    -------
    dict
        name -> {"estimate", "unit", "ci95", "plausible_range", "plausible": bool,
        "symbol", "meaning", "on_bound"}; ``plausible`` is False when the estimate
        lies outside :data:`PLAUSIBLE`; ``on_bound`` when it sits on an edge of the
        plausible range where the fit is bounded
        (:func:`~euc_sim.rides.balance.design.on_bound`): the most that plausible
        physics gives, while the data asks for more.
    """
    out: dict[str, dict] = {}
    for k in fit.names:
        est, ci = fit.estimate[k], list(fit.ci95[k])
        sym, unit, meaning, _, _ = CANDIDATES[k]
        rng = PLAUSIBLE.get(k)
        edge = on_bound(k, est)
        entry = {"estimate": est, "unit": unit, "ci95": ci, "symbol": sym, "meaning": meaning,
                 "plausible_range": list(rng[:2]) if rng else None, "on_bound": edge,
                 "plausible": bool(rng is None or rng[0] <= est <= rng[1])}
        if k == "aerodynamic_drag":
            entry["drag_area_m2"] = 2 * est / RHO_AIR
            entry["drag_area_m2_ci95"] = [2 * c / RHO_AIR for c in ci]
        if k == "road_slope":
            entry["angle_rad"] = math.asin(max(-1.0, min(1.0, est)))
        out[k] = entry
    return out
