"""The naming test of a pair of rides, its false-name control and its power.

A difference is named when OTHER's held-out error falls significantly with it
(:mod:`euc_sim.rides.compare.differences_fit`): OTHER's 30 s blocks, each
scored by the fit with its fold of *both* rides left out, give per block
``D_b = SSE_without,b − SSE_with,b``; a one-sided paired t-test of the mean
``D`` over the B blocks with B − 1 degrees of freedom (:func:`paired_test`; the
blocks the bootstrap already treats as independent), the p-values of a pair's
candidates adjusted by Benjamini–Hochberg (:func:`bh_qvalues`), and its 95 %
interval excluding zero.

Power: a difference Δ leaves, in OTHER's block b of the model without it, a
systematic error of sum of squares ``Δ²·S_b`` (``S_b``: the difference's
column on the block after the model's other columns, fitted on both rides
outside the fold, have absorbed what they can, per unit of the parameter),
less what estimating it on K−1 of K folds costs (``K/(K−1)·se²·S_b``), plus
``2Δ·X_b`` (``X_b``: that column against the residual's noise).  So
``E D_b = μ_b = (Δ² − K/(K−1)·se²)·S_b`` and the t-statistic's noncentrality is

    mean_b μ_b / √((var_b μ_b + v₀ + 4Δ²·mean_b X_b²) / B),

``v₀`` the blocks' spread of ``D_b`` with no difference (the pair's own, from
what the estimate leaves).  ``resolvable`` is the smallest Δ at which it
reaches the noncentrality that a t with B − 1 degrees of freedom passes its
one-sided level with probability :data:`POWER` (:func:`named_size`), or the
interval's half-width where that is larger.  A difference whose signature
varies much from block to block may never reach it (the ratio
``mean S/sd S·√B`` bounds the statistic): then only the interval resolves.  A
shift (the current's delay) has no column: only its interval (and the logs'
finest delay) resolves it.

Study: docs/concealed.md ("What a pair can resolve").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["Z95", "POWER", "Resolution", "paired_test", "bh_qvalues", "noncentrality", "block_means", "named_size",
           "predicted_gain", "heldout_signature_rms",
           "detectable_difference", "with_floor"]

#: Normal quantile of a two-sided 95 % interval.
Z95 = 1.959963984540054
#: The chance of naming at which a pair's ``resolvable`` is stated.
POWER = 0.8


@dataclass(frozen=True)
class Resolution:
    """The smallest difference of one parameter a pair of rides can name.

    Attributes
    ----------
    name : str
        The parameter.
    resolvable : float or None
        The larger of ``interval_halfwidth`` (plus ``floor``) and ``gate``, the
        parameter's unit; None without an interval.
    interval_halfwidth : float or None
        Half the 95 % interval's width, the parameter's unit.
    gate : float or None
        The size the naming test names with :data:`POWER` (:func:`named_size`),
        the parameter's unit; None for a shift.
    residual_rms : float or None
        OTHER's blocked held-out RMS with the difference modelled, the fitted
        signal's unit (W for battery power, V, m/s).
    signature_rms : float or None
        Held-out RMS of the difference's column after the model's other
        columns, the fitted signal's unit per unit of the parameter.
    floor : float
        The finest value the logs resolve (the delay's row interval), added to
        the half-width; 0 elsewhere.
    gain_se : float or None
        Standard error of the difference's measured held-out gain, from its
        spread over the folds (fraction).
    fold_sd : float or None
        √v₀, the spread of the test's per-block ``D_b`` with no difference
        (module docstring), the signal's unit squared.
    """

    name: str
    resolvable: float | None
    interval_halfwidth: float | None
    gate: float | None = None
    residual_rms: float | None = None
    signature_rms: float | None = None
    floor: float = 0.0
    gain_se: float | None = None
    fold_sd: float | None = None

    def to_json(self) -> dict:
        """The ``differences`` entry's ``resolution`` detail."""
        return {"interval_halfwidth": self.interval_halfwidth, "gate": self.gate,
                "residual_rms": self.residual_rms, "signature_rms": self.signature_rms,
                "floor": self.floor, "gain_se": self.gain_se, "fold_sd": self.fold_sd}


def paired_test(sse_with: np.ndarray, sse_without: np.ndarray) -> tuple[float, float, float]:
    """One-sided paired t-test that a term lowers OTHER's held-out error, over its blocks.

    Parameters
    ----------
    sse_with, sse_without : ndarray (B,)
        OTHER's held-out SSE per block (its fold of both rides left out) with
        and without the term, the signal's unit squared.

    Returns
    -------
    p : float
        P(T ≥ t) for t = mean(D)/(sd(D)/√B), ``D_b = without_b − with_b``, T a
        t with B − 1 degrees of freedom; 1 below two blocks or where every
        ``D_b`` is zero (a ride against itself).
    mean, sd : float
        Mean and standard deviation (ddof 1) of ``D`` over the blocks.
    """
    from scipy.stats import t as student

    d = np.asarray(sse_without, float) - np.asarray(sse_with, float)
    if len(d) < 2:
        return 1.0, 0.0, 0.0
    mean, sd = float(d.mean()), float(d.std(ddof=1))
    scale = float(np.abs(np.asarray(sse_with, float)).mean()) or 1.0
    if not sd > 1e-12 * scale:
        return (0.0 if mean > 1e-12 * scale else 1.0), mean, sd
    return float(student.sf(mean / (sd / math.sqrt(len(d))), len(d) - 1)), mean, sd


def bh_qvalues(p) -> np.ndarray:
    """Benjamini–Hochberg adjusted p-values (q-values) of a family of tests.

    ``q_(i) = min_{j ≥ i} p_(j)·m/j`` over the p-values sorted ascending, capped
    at 1: naming every test with ``q < α`` keeps the expected share of false
    names among the names below α (independent or positively dependent tests).

    Parameters
    ----------
    p : sequence of float

    Returns
    -------
    ndarray, in the order of ``p``
    """
    p = np.asarray(p, float)
    m = len(p)
    if m == 0:
        return p
    order = np.argsort(p)
    q = p[order] * m / np.arange(1, m + 1)
    q = np.minimum.accumulate(q[::-1])[::-1]
    out = np.empty(m)
    out[order] = np.minimum(q, 1.0)
    return out


def noncentrality(level: float, df: int, power: float = POWER) -> float:
    """δ: a noncentral t with ``df`` degrees of freedom exceeds its one-sided ``level``
    critical value with probability ``power``."""
    from scipy.optimize import brentq
    from scipy.stats import nct
    from scipy.stats import t as student

    crit = student.isf(level, df)
    return float(brentq(lambda nc: nct.sf(crit, df, nc) - power, 0.0, 200.0))


def block_means(size: float, signature_ss, se: float, n_folds: int) -> np.ndarray:
    """``E D_b = (Δ² − K/(K−1)·se²)·S_b`` per block (module docstring), the signal's unit squared.

    Parameters
    ----------
    size : float
        Δ, the parameter's unit.
    signature_ss : array_like (B,)
        S_b per unit of the parameter squared.
    se : float
        Standard error of the difference (parameter's unit).
    n_folds : int
        K.
    """
    return (size ** 2 - n_folds / (n_folds - 1.0) * se ** 2) * np.asarray(signature_ss, float)


def named_size(signature_ss, cross, se: float, null_var: float, *, level: float, n_folds: int,
               power: float = POWER) -> float | None:
    """Smallest difference :func:`paired_test` names with ``power`` at ``level`` (module docstring).

    Parameters
    ----------
    signature_ss : array_like (B,)
        S_b, the column's held-out sum of squares per block after the model's
        other columns, per unit of the parameter squared.
    cross : array_like (B,)
        X_b, that column against the residual of the model with it, per unit
        of the parameter.
    se : float
        Standard error of the difference (parameter's unit).
    null_var : float
        v₀, the spread (variance) of ``D_b`` over the blocks with no difference.
    level : float
        One-sided level the p-value must pass.
    n_folds : int
        K, the held-out folds.

    Returns
    -------
    float or None
        Δ_test in the parameter's unit; None where the column vanishes or no
        size reaches the power (found by bisection in log Δ).
    """
    S, X = np.asarray(signature_ss, float), np.asarray(cross, float)
    B = len(S)
    if B < 2 or not S.mean() > 0 or not np.isfinite(null_var):
        return None
    need = noncentrality(level, B - 1, power)

    def short(log_size: float) -> float:
        size = math.exp(log_size)
        mu = block_means(size, S, se, n_folds)
        spread = math.sqrt((mu.var(ddof=1) + null_var + 4.0 * size ** 2 * float(np.mean(X ** 2))) / B)
        return float(mu.mean()) - need * spread

    scale = math.sqrt((null_var + 1e-300) / float(S.mean()) ** 2) ** 0.5 + se
    lo, hi = math.log(scale * 1e-6 + 1e-300), math.log(scale * 1e6)
    if short(hi) < 0:
        return None
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if short(mid) < 0 else (lo, mid)
    return math.exp(hi)


def predicted_gain(size: float, residual_rms: float, signature_rms: float, se: float,
                   n_folds: int) -> float:
    """The held-out gain of modelling a difference of ``size``: ``1 − σ/√(σ² − e² + Δ²s²)``.

    ``σ``: OTHER's held-out RMS with the difference modelled, ``s``: its
    column's after the other columns per unit of the parameter, ``se`` its
    standard error, ``e² = K/(K−1)·s²·se²`` (``size``: Δ, the parameter's unit).
    """
    e2 = n_folds / (n_folds - 1.0) * (signature_rms * se) ** 2
    return 1.0 - residual_rms / math.sqrt(max(residual_rms ** 2 - e2 + (size * signature_rms) ** 2, 1e-300))


def heldout_signature_rms(GL: np.ndarray, fold_log: np.ndarray, GO: np.ndarray, fold_other: np.ndarray,
                          count_other: np.ndarray, others: list, col: int) -> float:
    """Held-out RMS of column ``col`` on OTHER's rows after the columns ``others`` (both rides).

    For each fold f the ``others`` are fitted to the column on both rides'
    blocks outside f (how the model without the difference absorbs its
    signature), and the remainder is scored on OTHER's blocks of fold f: the
    systematic error a unit difference leaves in OTHER's held-out residuals.

    Parameters
    ----------
    GL, GO : ndarray (n_blocks, p, p)
        Per-block Gram matrices of LOG's and OTHER's rows
        (:func:`euc_sim.rides.compare.differences_fit.block_grams`).
    fold_log, fold_other : ndarray (n_blocks,)
        Each block's fold.
    count_other : ndarray (n_blocks,)
        OTHER's rows per block.
    others : list of int
        The model's other columns.
    col : int
        The difference's column (its coefficient's unit).

    Returns
    -------
    float
    """
    sse, n = 0.0, 0
    for f in np.unique(fold_other):
        test = fold_other == f
        A = GL[fold_log != f].sum(axis=0) + GO[~test].sum(axis=0)
        beta = np.linalg.lstsq(A[np.ix_(others, others)], A[others, col], rcond=None)[0] if others else []
        T = GO[test].sum(axis=0)
        sse += float(T[col, col] - 2.0 * np.dot(beta, T[others, col]) + beta @ T[np.ix_(others, others)] @ beta
                     if others else T[col, col])
        n += int(count_other[test].sum())
    return float(np.sqrt(max(sse, 0.0) / n)) if n else 0.0


def detectable_difference(name: str, ci95, residual_rms: float | None = None,
                          signature_rms: float | None = None, *, blocks: tuple | None = None,
                          level: float = 0.05, n_folds: int = 5) -> Resolution:
    """The smallest difference of ``name`` the pair can name: the interval's half-width or the test's size.

    Parameters
    ----------
    name : str
    ci95 : (lo, hi) or None
        The difference's 95 % interval, the parameter's unit.
    residual_rms, signature_rms : float, optional
        OTHER's held-out RMS with the difference modelled and its column's
        after the other columns (reported).
    blocks : (signature_ss, cross, null_var), optional
        :func:`named_size`'s per-block parts; without them (a shift) only the
        interval resolves.
    level : float
        One-sided level the p-value must pass (the false-name rate over the
        candidates: the level of the smallest of their p-values).
    n_folds : int

    Returns
    -------
    Resolution
    """
    sd = None if blocks is None else float(math.sqrt(max(blocks[2], 0.0)))
    if ci95 is None:
        return Resolution(name, None, None, None, residual_rms, signature_rms, fold_sd=sd)
    half = 0.5 * float(ci95[1] - ci95[0])
    gate = None
    if blocks is not None:
        gate = named_size(blocks[0], blocks[1], half / Z95, blocks[2], level=level, n_folds=n_folds)
    best = half if gate is None else max(half, gate)
    return Resolution(name, float(best), half, gate, residual_rms, signature_rms, fold_sd=sd)


def with_floor(res: Resolution, floor: float) -> Resolution:
    """``res`` with the logs' finest resolvable value added to the interval's half-width (the delay)."""
    if res.interval_halfwidth is None:
        return replace(res, floor=float(floor))
    best = res.interval_halfwidth + floor
    return replace(res, floor=float(floor), resolvable=float(best if res.gate is None else max(best, res.gate)))
