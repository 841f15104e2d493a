"""Resampling and least-squares helpers shared by identification and the ride analyses.

Block bootstraps (moving blocks, wild block signs), percentile, basic and jackknife-t
intervals, the time folds of held-out validation, Gram-matrix least squares and a forward
selection scored on held-out error.  Every draw comes from the ``numpy.random.Generator``
passed in.  See docs/architecture.md#statistics-in-one-place.
"""

from __future__ import annotations

import functools
import sys
from typing import Callable, Sequence

import numpy as np
from threadpoolctl import ThreadpoolController

try:                    # the gufunc np.linalg.lstsq calls on one matrix (gram_lstsq_many: on a stack);
    from numpy.linalg import _umath_linalg      # numpy >= 2 names it lstsq (1.26: lstsq_m/lstsq_n)
    if not hasattr(_umath_linalg, "lstsq"):
        _umath_linalg = None
except ImportError:
    _umath_linalg = None

__all__ = ["gram_lstsq", "gram_lstsq_many", "one_blas_thread",
           "label_grams", "time_blocks", "span_blocks", "interleaved_folds", "forward_select", "percentile_interval",
           "basic_interval", "block_bootstrap_indices", "wild_block_signs", "blocks_by_length", "block_labels", "label_rows",
           "draw_blocks", "distinct", "moving_block_starts", "jackknife_interval", "rms"]


def gram_lstsq(G: np.ndarray, cols=None) -> tuple[np.ndarray, float]:
    """Least squares from a Gram matrix ``G = [X y]ᵀ[X y]`` (last row and column y).

    Returns ``beta``, the (minimum-norm) minimiser of |X·β − y|² over the columns ``cols``
    (default all), and the sum of squared residuals at it.
    """
    if cols is None:
        A, b = G[:-1, :-1], G[:-1, -1]
    else:
        cols = list(cols)
        A, b = G[np.ix_(cols, cols)], G[cols, -1]
    beta = np.linalg.lstsq(A, b, rcond=None)[0]
    return beta, float(G[-1, -1] - beta @ b)


def one_blas_thread():
    """A context in which BLAS runs on one thread (ride-long products gain nothing from more)."""
    return _threadpools(len(sys.modules)).limit(limits=1, user_api="blas")


@functools.lru_cache(maxsize=1)
def _threadpools(n_modules: int) -> ThreadpoolController:
    return ThreadpoolController()


def gram_lstsq_many(G: np.ndarray) -> np.ndarray:
    """:func:`gram_lstsq`'s ``beta`` (all columns) of each Gram matrix of a stack (..., p + 1, p + 1) → (..., p)."""
    G = np.asarray(G, dtype=float)
    A, b, p = G[..., :-1, :-1], G[..., :-1, -1:], G.shape[-1] - 1
    if _umath_linalg is None:       # a numpy without the gufunc: one call each
        return np.array([gram_lstsq(g)[0] for g in G.reshape(-1, p + 1, p + 1)]).reshape(G.shape[:-2] + (p,))
    with np.errstate(call=_lstsq_failed, invalid="call", over="ignore", divide="ignore", under="ignore"):
        x = _umath_linalg.lstsq(A, b, np.finfo(float).eps * p, signature="ddd->ddid")[0]
    return x[..., 0].copy()


def _lstsq_failed(err, flag):
    raise np.linalg.LinAlgError("SVD did not converge in Linear Least Squares")


def label_grams(Z: np.ndarray, labels: np.ndarray, n_labels: int) -> np.ndarray:
    """``Z[labels == b]ᵀ Z[labels == b]`` for each label b in 0 … n_labels − 1 (zero where none) → (n_labels, p, p)."""
    G = np.zeros((n_labels, Z.shape[1], Z.shape[1]))
    Z, ls = np.ascontiguousarray(Z), np.asarray(labels)
    if ls.size > 1 and not bool(np.all(ls[1:] >= ls[:-1])):   # each label's rows one slice: O(n) in all
        order = np.argsort(ls, kind="stable")
        Z, ls = Z[order], ls[order]
    bounds = np.flatnonzero(np.diff(ls)) + 1
    for lo, hi in zip(np.r_[0, bounds], np.r_[bounds, len(ls)]):
        if hi > lo:
            zb = Z[lo:hi]
            G[ls[lo]] = zb.T @ zb
    return G


def time_blocks(t: np.ndarray, n_blocks: int) -> np.ndarray:
    """Fold label 0 … n_blocks − 1 of each sample: contiguous blocks of equal counts (``t`` increasing, s)."""
    edges = np.quantile(t, np.linspace(0, 1, n_blocks + 1))
    return np.clip(np.searchsorted(edges, t, side="right") - 1, 0, n_blocks - 1)


def span_blocks(t: np.ndarray, n_blocks: int) -> np.ndarray:
    """Fold label 0 … n_blocks − 1 of each sample: contiguous blocks of equal durations (``t`` in s, any order)."""
    t = np.asarray(t, dtype=float)
    t0, t1 = t.min(), t.max()
    b = np.floor((t - t0) / (t1 - t0 + 1e-12) * n_blocks).astype(int)
    return np.clip(b, 0, n_blocks - 1)


def interleaved_folds(t: np.ndarray, n_folds: int, block: float,
                      guard: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """Folds ``[(train, test), ...]`` of blocked cross-validation.

    Blocks of about ``block`` s (at least ``n_folds``) are dealt to the folds in turn, so each
    fold holds out blocks spread over the record; training rows within ``guard`` s of a
    held-out row are dropped so a smoothing filter does not leak.  ``t`` in s, any order.
    """
    t = np.asarray(t, dtype=float)
    span = t.max() - t.min()
    blk = span_blocks(t, max(n_folds, int(np.floor(span / block))))
    order = np.argsort(t, kind="stable")
    ts = t[order]
    folds = []
    for f in range(n_folds):
        test_mask = (blk % n_folds) == f
        test = np.flatnonzero(test_mask)
        # distance of every sample to the nearest held-out sample, via the sorted times
        tt = np.unique(t[test])
        pos = np.searchsorted(tt, ts)
        left = np.abs(ts - tt[np.clip(pos - 1, 0, tt.size - 1)])
        right = np.abs(tt[np.clip(pos, 0, tt.size - 1)] - ts)
        near = np.empty(t.size, bool)
        near[order] = np.minimum(left, right) <= guard
        folds.append((np.flatnonzero(~test_mask & ~near), test))
    return folds


def rms(x) -> float:
    """Root mean square of the finite values of ``x``; NaN when there are none."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x ** 2))) if x.size else float("nan")


def distinct(a) -> np.ndarray:
    """``np.unique(a)`` of a 1-D array, in O(n) where ``a`` is already in order."""
    a = np.asarray(a)
    if a.ndim == 1 and a.dtype.kind in "iub" and (a.size < 2 or bool(np.all(a[1:] >= a[:-1]))):
        return a[np.r_[True, a[1:] != a[:-1]]] if a.size else a.copy()
    return np.unique(a)


def block_labels(t: np.ndarray, block: float, t0: float | None = None) -> np.ndarray:
    """Block number of each sample: consecutive ``block``-second stretches from ``t0`` (s)."""
    t = np.asarray(t, float)
    return np.floor((t - (t[0] if t0 is None else t0)) / block).astype(int)


def label_rows(label) -> list[np.ndarray]:
    """Row indices of each distinct value of ``label`` (e.g. a grid's segment), in label order."""
    label = np.asarray(label)
    return [np.flatnonzero(label == b) for b in distinct(label)]


def blocks_by_length(t: np.ndarray, block: float) -> list[np.ndarray]:
    """Row indices of consecutive ``block``-second stretches of ``t`` (s), in order."""
    return label_rows(block_labels(t, block))


def draw_blocks(n_blocks: int, rng: np.random.Generator) -> np.ndarray:
    """One replicate's block numbers: ``n_blocks`` drawn from 0 … n_blocks − 1 with replacement."""
    return rng.integers(0, n_blocks, n_blocks)


def moving_block_starts(n: int, L: int, n_boot: int, rng: np.random.Generator) -> np.ndarray:
    """Start samples (n_boot, ceil(n/L)) of a moving-block bootstrap of blocks of ``L`` samples."""
    return rng.integers(0, n - L + 1, size=(n_boot, int(np.ceil(n / L))))


def block_bootstrap_indices(blocks: Sequence[np.ndarray], rng: np.random.Generator) -> np.ndarray:
    """One moving-block bootstrap replicate: the rows of ``len(blocks)`` blocks drawn with replacement."""
    return np.concatenate([blocks[i] for i in draw_blocks(len(blocks), rng)])


def wild_block_signs(n: int, L: int, n_boot: int, rng: np.random.Generator) -> np.ndarray:
    """Rademacher signs (ceil(n / L), n_boot) of the blocks of ``L`` rows (row i: block i // L) for a wild block
    bootstrap."""
    n_blocks = int(np.ceil(n / L))
    return rng.choice(np.array([-1.0, 1.0]), size=(n_blocks, n_boot))


def percentile_interval(draws: np.ndarray, level: float = 0.95, axis: int = 0,
                        min_draws: int = 1) -> np.ndarray | None:
    """Equal-tailed percentile interval ``[lo, hi]`` of ``draws`` along ``axis`` (None below ``min_draws``)."""
    draws = np.asarray(draws, float)
    if draws.shape[axis] < max(min_draws, 1):
        return None
    a = (100.0 - 100.0 * level) / 2          # 2.5 exactly for 0.95 (100·(1 − 0.95)/2 is 2.500000000000002)
    return np.percentile(draws, [a, 100.0 - a], axis=axis)


def basic_interval(draws: np.ndarray, estimate: float, level: float = 0.95) -> tuple[float, float]:
    """Basic (reverse-percentile) interval ``(2·estimate − q_hi, 2·estimate − q_lo)`` of bootstrap ``draws``."""
    q_lo, q_hi = percentile_interval(np.ravel(draws), level)
    return float(2 * estimate - q_hi), float(2 * estimate - q_lo)


def jackknife_interval(estimate: float, leave_one_out, level: float = 0.95,
                       min_units: int = 3) -> tuple[float, float] | None:
    """Jackknife-t interval ``estimate ± t(K−1)·se`` from K leave-one-unit-out estimates.

    se² = (K−1)/K · Σ (θ₋ₖ − θ̄)² (Efron & Tibshirani 1993, §11.2).  None below ``min_units``
    estimates or when se is not finite.
    """
    from scipy.stats import t as student_t

    v = np.asarray(leave_one_out, float)
    k = len(v)
    if k < min_units:
        return None
    se = float(np.sqrt((k - 1) / k * np.sum((v - v.mean()) ** 2)))
    if not np.isfinite(se):
        return None
    half = float(student_t.ppf(0.5 + level / 2, k - 1)) * se
    return estimate - half, estimate + half


def forward_select(score: Callable[[list], float], base: list, candidates: list,
                   min_gain: float, max_step: int = 1) -> tuple[list, list]:
    """Forward selection by a held-out score: add the candidate that lowers it most.

    Parameters
    ----------
    score : callable
        ``score(names) -> float``, held-out error (``inf``: not admissible).
    base : list of str
        Terms always in the model.
    candidates : list of str
    min_gain : float
        A step is kept only if it lowers the score by more than this fraction.
    max_step : int
        2: a step may also add two terms that do not earn a step alone, when the pair
        beats both the current score and the best single term by ``min_gain``.

    Returns
    -------
    names : list of str
        ``base`` plus the kept terms, in order.
    history : list of dict
        ``{"term", "heldout_rmse"}`` per step, the base first (terms joined by "+").
    """
    names = list(base)
    cur = score(names)
    history = [{"term": "+".join(base), "heldout_rmse": cur}]
    left = list(candidates)
    while left:
        trial = {(c,): score(names + [c]) for c in left}
        best = min(trial, key=trial.get)
        alone = [c for c in left if not trial[(c,)] < cur * (1.0 - min_gain)]
        if max_step >= 2 and len(alone) >= 2:
            pairs = {(a, b): score(names + [a, b]) for i, a in enumerate(alone) for b in alone[i + 1:]}
            pair = min(pairs, key=pairs.get)
            if pairs[pair] < min(trial[best], cur) * (1.0 - min_gain):
                best, trial[pair] = pair, pairs[pair]
        if not np.isfinite(trial[best]) or trial[best] > cur * (1.0 - min_gain):
            break
        names += list(best)
        left = [c for c in left if c not in best]
        cur = trial[best]
        history.append({"term": "+".join(best), "heldout_rmse": cur})
    return names, history
