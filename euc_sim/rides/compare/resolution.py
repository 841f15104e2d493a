"""The naming test of a pair of rides, its false-name control and its power.

A cross-fitted score test: for each of OTHER's 30 s blocks, both rides' fold left out,
the difference's column after the model's others against the residual without it gives
X⁰_b (with it modelled, X_b), and z = Σ_b X⁰_b / √(Σ_b X_b²) is tested against a t with
B − 1 degrees of freedom (:func:`score_test`).  A difference Δ adds Δ·S_b to each X⁰_b, so
the smallest named with :data:`POWER` is δ·√(ΣX_b²)/ΣS_b (:func:`named_size`).  p-values
are adjusted by Benjamini–Hochberg (:func:`bh_qvalues`); a shift (the current's delay) is
tested by the paired t of the blocks' held-out SSE drop (:func:`paired_test`).  Study:
docs/concealed.md ("What a pair can resolve").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["Z95", "POWER", "Resolution", "paired_test", "score_test", "bh_qvalues", "noncentrality", "named_size",
           "predicted_gain", "heldout_signature_rms",
           "detectable_difference", "with_floor"]

#: Normal quantile of a two-sided 95 % interval.
Z95 = 1.959963984540054
#: The chance of naming at which a pair's ``resolvable`` is stated.
POWER = 0.8


@dataclass(frozen=True)
class Resolution:
    """The smallest difference of one parameter a pair of rides can name (parameter's unit).

    Attributes
    ----------
    name : str
    resolvable : float or None
        The larger of ``interval_halfwidth`` (plus ``floor``) and ``gate``.
    interval_halfwidth : float or None
        Half the 95 % interval's width.
    gate : float or None
        The size the naming test names with :data:`POWER`; None for a shift.
    residual_rms : float or None
        OTHER's blocked held-out RMS with the difference modelled, the signal's unit (1
        where channels are stacked, each whitened).
    signature_rms : float or None
        Held-out RMS of the difference's column after the others, per unit of the parameter.
    floor : float
        The finest value the logs resolve (the delay's row interval); 0 elsewhere.
    gain_se : float or None
        Standard error of the measured held-out gain (fraction).
    fold_sd : float or None
        √(Σ X_b²), the score's spread with no difference.
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


def paired_test(sse_with: np.ndarray, sse_without: np.ndarray) -> tuple[float, float, float]:
    """One-sided paired t-test that a term lowers OTHER's held-out error over its blocks.

    ``sse_with``, ``sse_without`` (B,): OTHER's held-out SSE per block.  Returns P(T ≥ t) for
    t = mean(D)/(sd(D)/√B), D_b = without_b − with_b (1 below two blocks or with every D_b
    zero), and the mean and sd (ddof 1) of D.
    """
    from scipy.stats import t as student

    w = np.asarray(sse_with, float)
    d = np.asarray(sse_without, float) - w
    if len(d) < 2:
        return 1.0, 0.0, 0.0
    mean, sd = float(d.mean()), float(d.std(ddof=1))
    tiny = 1e-12 * (float(np.abs(w).mean()) or 1.0)
    if not sd > tiny:
        return (0.0 if mean > tiny else 1.0), mean, sd
    return float(student.sf(mean / (sd / math.sqrt(len(d))), len(d) - 1)), mean, sd


def bh_qvalues(p) -> np.ndarray:
    """Benjamini–Hochberg q-values of a family of p-values, in their order: q_(i) = min_{j ≥ i}
    p_(j)·m/j capped at 1 (scipy's ``false_discovery_control``).
    """
    from scipy.stats import false_discovery_control

    p = np.asarray(p, float)
    return p if p.size == 0 else false_discovery_control(p, method="bh")


def noncentrality(level: float, df: int) -> float:
    """δ: a noncentral t with ``df`` degrees of freedom exceeds its one-sided ``level``
    critical value with probability :data:`POWER`."""
    from scipy.optimize import brentq
    from scipy.stats import nct
    from scipy.stats import t as student

    crit = student.isf(level, df)
    return float(brentq(lambda nc: nct.sf(crit, df, nc) - POWER, 0.0, 200.0))


def score_test(cross_without, cross_with) -> tuple[float, float]:
    """Two-sided cross-fitted score test of one difference (module docstring): ``cross_without``,
    ``cross_with`` are X⁰_b and X_b (B,).  Returns p = 2·P(T ≥ |z|) (1 where the noise vanishes
    or below two blocks) and z.
    """
    from scipy.stats import t as student

    x0, x = np.asarray(cross_without, float), np.asarray(cross_with, float)
    den = math.sqrt(float(np.sum(x ** 2)))
    if len(x) < 2 or not den > 1e-12 * (abs(float(x0.sum())) + 1e-300) or not den > 0:
        return 1.0, 0.0
    z = float(x0.sum()) / den
    return float(min(1.0, 2.0 * student.sf(abs(z), len(x) - 1))), z


def named_size(signature_ss, cross_with, *, level: float) -> float | None:
    """Smallest difference :func:`score_test` names with :data:`POWER` at two-sided ``level``:
    δ·√(ΣX_b²)/ΣS_b from ``signature_ss`` S_b and ``cross_with`` X_b (per unit of the
    parameter); None where the column vanishes.
    """
    S, X = np.asarray(signature_ss, float), np.asarray(cross_with, float)
    if len(S) < 2 or not S.sum() > 0:
        return None
    return noncentrality(level / 2.0, len(S) - 1) * math.sqrt(float(np.sum(X ** 2))) / float(S.sum())


def predicted_gain(size: float, residual_rms: float, signature_rms: float, se: float,
                   n_folds: int) -> float:
    """The held-out gain of modelling a difference Δ = ``size``: 1 − σ/√(σ² − e² + Δ²s²), σ =
    ``residual_rms``, s = ``signature_rms``, e² = K/(K−1)·s²·se².
    """
    e2 = n_folds / (n_folds - 1.0) * (signature_rms * se) ** 2
    return 1.0 - residual_rms / math.sqrt(max(residual_rms ** 2 - e2 + (size * signature_rms) ** 2, 1e-300))


def heldout_signature_rms(GL: np.ndarray, fold_log: np.ndarray, GO: np.ndarray, fold_other: np.ndarray,
                          count_other: np.ndarray, others: list, col: int) -> float:
    """Held-out RMS of column ``col`` on OTHER's rows after the columns ``others``, each fold's
    ``others`` fitted on both rides' blocks outside it (``GL``, ``GO``: per-block Gram
    matrices; ``fold_*``, ``count_other`` per block): the error a unit difference leaves.
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
                          level: float = 0.05) -> Resolution:
    """The smallest difference of ``name`` the pair can name: the 95 % interval's half-width or
    the test's size (:func:`named_size` of ``blocks``; without them, a shift, the interval
    alone), at ``level`` (the false-name rate over the candidates).
    """
    sd = None if blocks is None else float(math.sqrt(np.sum(np.asarray(blocks[1], float) ** 2)))
    if ci95 is None:
        return Resolution(name, None, None, None, residual_rms, signature_rms, fold_sd=sd)
    half = 0.5 * float(ci95[1] - ci95[0])
    gate = None
    if blocks is not None:
        gate = named_size(blocks[0], blocks[1], level=level)
    best = half if gate is None else max(half, gate)
    return Resolution(name, float(best), half, gate, residual_rms, signature_rms, fold_sd=sd)


def with_floor(res: Resolution, floor: float) -> Resolution:
    """``res`` with the logs' finest resolvable value added to the interval's half-width (the delay)."""
    if res.interval_halfwidth is None:
        return replace(res, floor=float(floor))
    best = res.interval_halfwidth + floor
    return replace(res, floor=float(floor), resolvable=float(best if res.gate is None else max(best, res.gate)))
