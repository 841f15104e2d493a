"""One least-squares fit of two rides: shared nuisance terms, OTHER-only difference terms Δθ.

LOG's rows carry the shared columns, OTHER's the same plus one column per difference
(zero on LOG's), so each Δθ is what OTHER needs beyond the shared model; a difference of
the current's delay is a shift of OTHER's columns, chosen on a grid.  Everything comes
from per-block Gram matrices ``[X y]ᵀ[X y]`` within :func:`euc_sim.stats.time_blocks`
folds: the naming test (both rides' fold k left out, OTHER's scored;
:func:`~euc_sim.rides.compare.resolution.score_test`) drives a forward selection, and the
95 % interval is the hull of a block bootstrap (each ride's blocks drawn independently)
and a jackknife-t over paired fractions of the rides (how the difference changes along
them).  Study: docs/concealed.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from euc_sim.rides.compare.resolution import (detectable_difference, heldout_signature_rms, paired_test,
                                               score_test)
from euc_sim.stats import draw_blocks, gram_lstsq, jackknife_interval, label_grams, percentile_interval, time_blocks

__all__ = ["PairDesign", "PairFit", "DELAY", "block_grams", "pair_fit"]

#: The name of the shift candidate (OTHER's current delay beyond LOG's).
DELAY = "current_delay"
#: |correlation| of two differences' estimates beyond which the pair cannot tell them apart.
ALIAS_SET_CORRELATION = 0.98


@dataclass(frozen=True)
class PairDesign:
    """Both rides' rows of one domain.

    Attributes
    ----------
    names, deltas : tuple of str
        Column names of ``X`` (shared and per-ride terms, then the differences); the
        difference columns.
    t_log, Z_log : ndarray
        LOG's times (s) and ``[X y]`` rows (difference columns zero).
    t_other : ndarray
        OTHER's times, s.
    Z_other : tuple of ndarray
        OTHER's ``[X y]`` rows at each shift of the grid, the middle entry no shift.
    shift_step : float
        Seconds per grid step.
    """

    names: tuple
    deltas: tuple
    t_log: np.ndarray
    Z_log: np.ndarray
    t_other: np.ndarray
    Z_other: tuple
    shift_step: float = 0.0


@dataclass(frozen=True)
class PairFit:
    """Outcome of :func:`pair_fit`.

    Attributes
    ----------
    selected : list of str
        The differences kept (each the smallest p-value left, below ``level``).
    estimates : dict of str -> (estimate, (lo, hi)) or None
        Each candidate in the selected model (plus itself), with its 95 % interval; the
        shift in s.
    gains : dict of str -> float
        Each candidate's fractional drop of OTHER's held-out RMS.
    correlations : dict of str -> dict of str -> float
        Correlation of the differences' estimates fitted together (near ±1: not told apart).
    resolutions : dict of str -> Resolution
        Each candidate's smallest nameable size on this pair.
    p_values : dict of str -> float
        Each candidate's p-value against the selected model (a kept one without it).
    alias_sets : dict of str -> list of str
        For a kept candidate, itself and those the pair cannot tell it from.
    """

    selected: list
    estimates: dict
    gains: dict
    correlations: dict
    resolutions: dict = field(default_factory=dict)
    p_values: dict = field(default_factory=dict)
    alias_sets: dict = field(default_factory=dict)


def _block_ids(t: np.ndarray, n_folds: int, block: float) -> tuple[np.ndarray, np.ndarray]:
    """Block number of each row and the fold of each block (blocks of ``block`` s inside folds)."""
    fold = time_blocks(t, n_folds)
    ids = np.empty(len(t), int)
    folds, n = [], 0
    for f in range(n_folds):
        rows = np.flatnonzero(fold == f)
        if len(rows) == 0:
            continue
        sub = np.floor((t[rows] - t[rows].min()) / block).astype(int)
        _, sub = np.unique(sub, return_inverse=True)
        ids[rows] = n + sub
        folds += [f] * (sub.max() + 1)
        n += sub.max() + 1
    return ids, np.array(folds)


def block_grams(t: np.ndarray, Zs, n_folds: int = 5, block: float = 30.0
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-block Gram matrices (len(Zs), n_blocks, p, p) of each of ``Zs`` (rows × columns, their rows at
    the times ``t``, s, cut into blocks once), each block's fold and row count."""
    ids, fold = _block_ids(t, n_folds, block)
    return np.stack([label_grams(Z, ids, len(fold)) for Z in Zs]), fold, np.bincount(ids, minlength=len(fold))


def _parabola(sse: np.ndarray, k: int) -> float:
    """Sub-step position of the minimum of ``sse`` near index ``k`` (a parabola through three points)."""
    if k == 0 or k == len(sse) - 1:
        return float(k)
    a, b, c = sse[k - 1], sse[k], sse[k + 1]
    den = a - 2.0 * b + c
    return float(k) if den <= 0 else k + 0.5 * (a - c) / den


class _Grams:
    """The design's block Gram matrices and the fits drawn from them."""

    def __init__(self, d: PairDesign, n_folds: int, block: float):
        self.names, self._deltas = list(d.names), tuple(d.deltas)
        (self.GL,), self.fL, _ = block_grams(d.t_log, [d.Z_log], n_folds, block)
        self.GO, self.fO, self.nO = block_grams(d.t_other, d.Z_other, n_folds, block)
        self.mid = len(d.Z_other) // 2
        self.step = d.shift_step
        self.n_folds = n_folds
        self._fold_fits: dict[tuple, tuple] = {}
        self._block_sse: dict[tuple, np.ndarray] = {}

    def cols(self, terms) -> list:
        keep = [n for n in self.names if n not in self._deltas or n in terms]
        return [self.names.index(n) for n in keep]

    def fit(self, wL, wO, terms):
        """(β, shift index, SSE by shift) with block weights ``wL``, ``wO``."""
        cols = self.cols(terms)
        GL = np.tensordot(wL, self.GL, axes=1)
        ks = range(len(self.GO)) if DELAY in terms else [self.mid]
        fits = {k: gram_lstsq(GL + np.tensordot(wO, self.GO[k], axes=1), cols) for k in ks}
        sse = np.array([fits[k][1] for k in ks])
        k = list(ks)[int(np.argmin(sse))]
        return fits[k][0], k, sse

    def fold_fit(self, f: int, terms):
        """:meth:`fit` with fold ``f`` of both rides left out, once per model and fold.

        The held-out score and the paired-fraction jackknife leave out the same folds.
        """
        key = (f, tuple(terms))
        if key not in self._fold_fits:
            self._fold_fits[key] = self.fit((self.fL != f).astype(float),
                                            (self.fO != f).astype(float), terms)
        return self._fold_fits[key]

    def block_sse(self, terms) -> np.ndarray:
        """OTHER's held-out SSE per block, each block scored by the fit with its fold of both rides left out."""
        key = tuple(terms)
        if key in self._block_sse:
            return self._block_sse[key]
        cols, sse = self.cols(terms), np.zeros(len(self.fO))
        for f in range(self.n_folds):
            test = self.fO == f
            if not test.any():
                continue
            beta, k, _ = self.fold_fit(f, terms)
            G = self.GO[k][test]
            sse[test] = (G[:, -1, -1] - 2.0 * G[:, cols, -1] @ beta
                         + np.einsum("i,bij,j->b", beta, G[:, cols][:, :, cols], beta))
        self._block_sse[key] = sse
        return sse

    def fold_sse(self, terms) -> tuple[np.ndarray, np.ndarray]:
        """OTHER's held-out SSE and rows per fold (fold f of both rides left out, OTHER's fold f scored)."""
        sse, folds = self.block_sse(terms), [f for f in range(self.n_folds) if (self.fO == f).any()]
        return (np.array([sse[self.fO == f].sum() for f in folds]),
                np.array([int(self.nO[self.fO == f].sum()) for f in folds]))

    def score(self, terms) -> float:
        """Blocked held-out RMS of OTHER: fold f of both rides left out, OTHER's fold f scored."""
        sse, n = self.fold_sse(terms)
        return float(np.sqrt(max(float(sse.sum()), 0.0) / n.sum())) if n.sum() else np.inf

    def test(self, base, c: str) -> float:
        """p-value of adding ``c`` to the model ``base`` (:func:`score_test`; the shift: :func:`paired_test`)."""
        terms = list(base) + [c]
        if c == DELAY:
            return paired_test(self.block_sse(terms), self.block_sse(list(base)))[0]
        key = ("test", tuple(terms))
        if key not in self._block_sse:
            S, X, X0 = _block_parts(self, terms, c)
            self._block_sse[key] = score_test(X0, X)[0]
        return self._block_sse[key]

    def gain_se(self, terms, c: str) -> float | None:
        """Standard error of ``c``'s held-out gain from its spread over the folds (None below 2 folds)."""
        (w, n), (wo, _) = self.fold_sse(terms), self.fold_sse([x for x in terms if x != c])
        ok = (wo > 0) & (n > 0)
        if ok.sum() < 2:
            return None
        g = 1.0 - np.sqrt(np.clip(w[ok], 0.0, None) / wo[ok])
        return float(np.std(g, ddof=1) / np.sqrt(ok.sum()))


def _draws(g: _Grams, terms, cands, transform, n_boot: int, rng) -> dict[str, list[float]]:
    """Bootstrap draws of each candidate's value, each ride's blocks drawn independently."""
    cols = g.cols(terms)
    out = {c: [] for c in cands}
    weights = lambda n: np.bincount(draw_blocks(n, rng), minlength=n).astype(float)   # noqa: E731
    for _ in range(n_boot):
        wL = weights(len(g.fL))
        beta, k, sse = g.fit(wL, weights(len(g.fO)), terms)
        vals = _values(g, cols, beta, k, sse, terms, transform)
        for c in cands:
            out[c].append(vals[c])
    return out


def _jackknife(g: _Grams, terms, cands, transform, whole: dict) -> dict[str, tuple[float, float] | None]:
    """Jackknife-t 95 % interval of each candidate over paired fractions.

    Pair-unit ``k`` is fold ``k`` of LOG together with fold ``k`` of OTHER,
    each left out in turn (:func:`euc_sim.stats.jackknife_interval` around the
    whole-pair estimate; None below three units).
    """
    cols, parts = g.cols(terms), []
    for f in range(g.n_folds):
        if not ((g.fL == f).any() and (g.fO == f).any()):
            continue
        beta, k, sse = g.fold_fit(f, terms)
        parts.append(_values(g, cols, beta, k, sse, terms, transform))
    return {c: jackknife_interval(whole[c], [p[c] for p in parts]) for c in cands}


def _hull(a, b):
    """The smallest interval holding both ``a`` and ``b`` (either may be None)."""
    if a is None or b is None:
        return a if b is None else b
    return (float(min(a[0], b[0])), float(max(a[1], b[1])))


def _values(g: _Grams, cols, beta, k, sse, terms, transform) -> dict[str, float]:
    coef = {g.names[i]: float(b) for i, b in zip(cols, beta)}
    vals = {n: transform.get(n, lambda c, n=n: c[n])(coef) for n in terms if n != DELAY}
    if DELAY in terms:
        vals[DELAY] = (_parabola(sse, k) - g.mid) * g.step
    return vals


def _select(g: _Grams, cands: list, level: float) -> list:
    """Forward selection by the naming test: the candidate of smallest p-value added while below ``level``."""
    selected, left = [], list(cands)
    while left:
        ps = {c: g.test(selected, c) for c in left}
        best = min(left, key=ps.get)
        if not ps[best] < level:
            break
        selected.append(best)
        left.remove(best)
    return selected


def _alias_set(g: _Grams, selected: list, c: str, cands: list, corr: dict, level: float) -> list:
    """``c`` and the candidates this pair cannot tell it from (correlation beyond
    :data:`ALIAS_SET_CORRELATION`, or each significant alone but neither beyond the other), or [].
    """
    out = []
    for o in cands:
        if o == c:
            continue
        base = [x for x in selected if x not in (c, o)]
        if abs(corr.get(c, {}).get(o, 0.0)) > ALIAS_SET_CORRELATION or (
                g.test(base, o) < level and g.test(base, c) < level
                and not g.test(base + [o], c) < level and not g.test(base + [c], o) < level):
            out.append(o)
    return [c, *out] if out else []


def pair_fit(design: PairDesign, *, level: float = 0.05, family: int = 1, transform: dict | None = None,
             n_folds: int = 5, block: float = 30.0,
             n_boot: int = 200, seed: int = 0) -> PairFit:
    """Forward-select the differences by the naming test, then size each: bootstrap and jackknife.

    Parameters
    ----------
    design : PairDesign
    level : float
        One-sided p-value below which the selection adds a candidate.
    family : int
        Candidates the caller's false-name control spans: the resolution is stated at
        ``level / family``.
    transform : dict of str -> callable, optional
        ``f(coefficients) -> value`` of a difference in its parameter's units.
    n_folds, block : int, float
        Held-out folds per ride and bootstrap blocks, s.
    n_boot, seed : int
    """
    g = _Grams(design, n_folds, block)
    cands = list(design.deltas) + ([DELAY] if len(design.Z_other) > 1 else [])
    selected = _select(g, cands, level)
    transform = transform or {}
    rng = np.random.default_rng(seed)
    estimates, gains, resolutions, p_values = {}, {}, {}, {}
    models = [selected] + [selected + [c] for c in cands if c not in selected]
    for terms in models:
        shown = [c for c in terms if c not in estimates]
        beta, k, sse = g.fit(np.ones(len(g.fL)), np.ones(len(g.fO)), terms)
        whole = _values(g, g.cols(terms), beta, k, sse, terms, transform)
        draws = _draws(g, terms, shown, transform, n_boot, rng)
        jack = _jackknife(g, terms, shown, transform, whole)
        for c in shown:
            ci = percentile_interval(np.asarray(draws[c]))
            boot = None if ci is None else (float(ci[0]), float(ci[1]))
            estimates[c] = (whole[c], _hull(boot, jack[c]) if boot is not None else None)
            without = [x for x in terms if x != c]
            p_values[c] = g.test(without, c)
            with_ = g.score(terms)
            gains[c] = 1.0 - with_ / g.score(without) if g.score(without) > 0 else 0.0
            resolutions[c] = replace(_resolution(g, terms, c, k, beta, transform, estimates[c], with_,
                                                 level / max(family, 1)),
                                     gain_se=g.gain_se(terms, c))
    corr = _correlations(g)
    alias_sets = {c: a for c in selected if (a := _alias_set(g, selected, c, cands, corr, level))}
    return PairFit(selected, estimates, gains, corr, resolutions, p_values, alias_sets)


def _resolution(g: _Grams, terms, c: str, k: int, beta, transform: dict, estimate, residual: float,
                level: float):
    """``c``'s Resolution in the model ``terms``: its column's held-out RMS after the others and
    its per-block parts (:func:`_block_parts`), per unit of the parameter.
    """
    ci = estimate[1]
    if c == DELAY:
        return detectable_difference(c, ci, level=level)
    cols = g.cols(terms)
    col = g.names.index(c)
    others = [i for i in cols if i != col]
    s = heldout_signature_rms(g.GL, g.fL, g.GO[k], g.fO, g.nO, others, col)
    coef = {g.names[i]: float(b) for i, b in zip(cols, beta)}
    fn = transform.get(c, lambda co: co[c])
    slope = abs(fn({**coef, c: coef[c] + 1.0}) - fn(coef))
    if not slope > 0:
        return detectable_difference(c, ci, level=level)
    S, X, _ = _block_parts(g, terms, c)
    return detectable_difference(c, ci, residual, s / slope, blocks=(S / slope ** 2, X / slope), level=level)


def _block_parts(g: _Grams, terms, c: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per OTHER block, ``S_b`` (sum of squares of ``c``'s column after the others) and ``X_b``,
    ``X⁰_b`` (that column against the residual with and without ``c``), each fitted outside
    the block's fold, per coefficient unit.
    """
    cols, col = g.cols(terms), g.names.index(c)
    others = [i for i in cols if i != col]
    without = [x for x in terms if x != c]
    p = g.GL.shape[1]
    S, X, X0 = (np.zeros(len(g.fO)) for _ in range(3))
    for f in range(g.n_folds):
        test = g.fO == f
        if not test.any():
            continue
        beta, k, _ = g.fold_fit(f, terms)
        beta0 = g.fold_fit(f, without)[0]
        A = g.GL[g.fL != f].sum(axis=0) + g.GO[k][~test].sum(axis=0)
        u = np.zeros(p)
        u[col] = 1.0
        if others:
            u[others] -= np.linalg.lstsq(A[np.ix_(others, others)], A[others, col], rcond=None)[0]
        v, v0 = np.zeros(p), np.zeros(p)
        v[-1] = v0[-1] = 1.0
        v[cols] -= beta
        v0[g.cols(without)] -= beta0
        G = g.GO[k][test]
        S[test] = np.einsum("i,bij,j->b", u, G, u)
        X[test] = np.einsum("i,bij,j->b", u, G, v)
        X0[test] = np.einsum("i,bij,j->b", u, G, v0)
    return S, X, X0


def _correlations(g: _Grams) -> dict[str, dict[str, float]]:
    """Correlations of the differences' estimates with every difference in the model (no shift)."""
    cols = g.cols(g._deltas)
    G = g.GL.sum(axis=0) + g.GO[g.mid].sum(axis=0)
    C = np.linalg.pinv(G[np.ix_(cols, cols)])
    idx = {g.names[c]: i for i, c in enumerate(cols) if g.names[c] in g._deltas}
    sd = np.sqrt(np.clip(np.diag(C), 1e-300, None))
    return {a: {b: float(C[i, j] / (sd[i] * sd[j])) for b, j in idx.items() if b != a}
            for a, i in idx.items()}
