"""Least-squares fit of a ride's balance with wild block bootstrap intervals.

:func:`fit_balance` fits a :class:`~euc_sim.rides.balance.design.Design` by bounded least
squares on its Gram matrix (:mod:`~euc_sim.rides.balance.normal`); :func:`plausibility`
turns a fit into physical estimates with units and flags.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from euc_sim.errors import InputError
from euc_sim.rides.balance.design import CANDIDATES, NOMINAL, PLAUSIBLE, Design, on_bound
from euc_sim.rides.balance.normal import solve_gram, solve_grams
from euc_sim.simulation.effects import RECORDS
from euc_sim.stats import percentile_interval, wild_block_signs

__all__ = ["BalanceFit", "fit_balance", "block_rows", "plausibility", "MIN_BLOCKS", "FEW_BLOCKS"]

#: Fewest bootstrap blocks a fit with intervals accepts: with one block every
#: replicate resamples the whole residual in order, and the interval has zero width.
MIN_BLOCKS = 2
#: Below this many blocks the intervals are rough (reported as a note).
FEW_BLOCKS = 5

@dataclass(frozen=True)
class BalanceFit:
    """A least-squares fit of a :class:`Design`, with block-bootstrap intervals.

    Attributes
    ----------
    names : tuple of str
        Fitted parameters (keys of :data:`CANDIDATES`).
    estimate, ci95 : dict
        Value of each (unit of :data:`CANDIDATES`) and its 95 % wild block bootstrap interval.
    rmse : float
        In-sample RMS weighted residual, W or N·m.
    n : int
        Rows used.
    n_boot, block_s, seed :
        Bootstrap settings.
    unit : str
    boot_corr : dict
        ``{(a, b): r}`` correlation of the replicates; |r| near 1: a and b not told apart.
    """

    names: tuple[str, ...]
    estimate: Mapping[str, float]
    ci95: Mapping[str, tuple[float, float]]
    rmse: float
    n: int
    n_boot: int
    block_s: float
    seed: int
    unit: str = "W"
    boot_corr: Mapping[tuple[str, str], float] = None

    def confounded(self, name: str) -> tuple[str, ...]:
        """Parameters whose bootstrap replicates correlate with ``name``'s beyond ±0.8."""
        if not self.boot_corr:
            return ()
        return tuple(b for (a, b), r in self.boot_corr.items()
                     if a == name and b != name and abs(r) >= 0.8)

    def rmse_on(self, design: Design) -> float:
        """RMS weighted residual of this fit on another design, W or N·m."""
        r = design.residual(self.estimate)
        return float(np.sqrt(np.mean(r ** 2)))


def _solve(design: Design, names: Sequence[str], P: np.ndarray | None = None):
    """The bounded least-squares fit of the balance on ``design``'s rows, from the Gram
    matrix of its basis (:func:`~euc_sim.rides.balance.normal.solve_gram`); ``P``
    replaces the measured power (rows in use, W)."""
    if P is None:
        G = design.gram
    else:
        Z = design.basis.Z.copy()
        Z[:, -1] = design.weight * P
        G = Z.T @ Z
    return solve_gram(G, design.basis.columns, names)


def block_rows(design: Design, block_s: float = 10.0, check: bool = True) -> int:
    """Rows per bootstrap block of ``block_s`` s; ValueError (with ``check``) naming the ride
    when its rows in use hold fewer than :data:`MIN_BLOCKS` blocks.
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


def _bootstrap(design: Design, names: Sequence[str], fitted_P: np.ndarray, e_P: np.ndarray, L: int,
               n_boot: int, seed: int):
    """Wild block bootstrap: 2.5/97.5 percentiles and replicate correlations.

    Each replicate flips the sign of whole blocks of ``L`` residuals, each left at its own
    row (Rademacher weights), keeping the autocorrelation and the residual's dependence on
    the regime; a parameter on its bound stays within it.  Only the measured power's row of
    the Gram matrix changes, so the replicates are fitted together
    (:func:`~euc_sim.rides.balance.normal.solve_grams`).
    """
    n = len(e_P)
    if not len(names):
        return np.empty(0), np.empty(0), {}
    if not n_boot:
        nan = np.full(len(names), np.nan)
        return nan, nan, {}
    rng = np.random.default_rng(seed)
    signs = wild_block_signs(n, L, n_boot, rng)                 # one sign per block
    w = design.weight
    X, f, g = design.basis.Z[:, :-1], w * fitted_P, w * e_P
    starts = np.arange(0, n, L)
    Xg = np.add.reduceat(X * g[:, None], starts, axis=0)         # blocks × basis
    fg = np.add.reduceat(f * g, starts)
    G = np.empty((n_boot, X.shape[1] + 1, X.shape[1] + 1))
    G[:, :-1, :-1] = X.T @ X
    G[:, :-1, -1] = G[:, -1, :-1] = (X.T @ f)[None] + signs.T @ Xg
    G[:, -1, -1] = f @ f + 2.0 * signs.T @ fg + g @ g
    boots = solve_grams(G, design.basis.columns, names)
    corr = {}
    lo, hi = percentile_interval(boots)
    if n_boot > 2:
        with np.errstate(invalid="ignore", divide="ignore"):
            C = np.corrcoef(boots, rowvar=False)
        corr = {(a, b): float(C[i, j]) for i, a in enumerate(names)
                for j, b in enumerate(names) if i != j and np.isfinite(C[i, j])}
    return lo, hi, corr


def fit_balance(design: Design, names: Sequence[str] | None = None, n_boot: int = 200,
                block_s: float = 10.0, seed: int = 0) -> BalanceFit:
    """Bounded least squares with wild block bootstrap 95 % intervals (:func:`_bootstrap`).

    Parameters
    ----------
    design : Design
    names : sequence of str, optional
        Parameters to fit (default ``design.candidates``); none: the inertia-only model.
    n_boot : int
        Bootstrap replicates (0: NaN intervals).
    block_s : float
        Block length, s.
    seed : int
        Seed of ``numpy.random.default_rng``.

    Raises
    ------
    ValueError
        Naming the ride: too few rows for the parameters, or (``n_boot`` > 0) fewer than
        :data:`MIN_BLOCKS` blocks.
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
    res = _solve(design, names)
    theta = res.x
    est = dict(zip(names, map(float, theta)))
    fitted_P = design.predict(est)
    # Unweighted residuals in P units are what gets resampled.
    e_P = design.P - fitted_P
    e = design.weight * e_P                 # design.residual(est), its prediction not redone
    lo, hi, corr = _bootstrap(design, names, fitted_P, e_P, L, n_boot, seed)
    # a bounded estimate's replicates can pile up on one side of it (on or near its bound):
    # the interval reaches out to the estimate, widened, never narrowed
    lo, hi = np.fmin(lo, theta), np.fmax(hi, theta)
    return BalanceFit(names=tuple(names), estimate=est,
                      ci95={k: (float(a), float(b)) for k, a, b in zip(names, lo, hi)},
                      rmse=float(np.sqrt(np.mean(e ** 2))), n=n, n_boot=n_boot,
                      block_s=block_s, seed=seed, unit=design.unit, boot_corr=corr)


def plausibility(fit: BalanceFit) -> dict[str, dict]:
    """Physical estimates of a fit, with units, intervals and plausibility flags.

    Adds the drag area C_dA = 2k/ρ (ρ = 1.2 kg/m³) and the road angle
    α = arcsin(sin α) where they apply (the record's ``json_extra``).

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
        json_extra = RECORDS.get(k).balance.json_extra
        if json_extra is not None:
            entry.update(json_extra(est, ci))
        out[k] = entry
    return out
