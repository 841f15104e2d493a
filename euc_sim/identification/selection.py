"""Generic selection of named candidate terms for a residual, with a nuisance parameter.

This module knows nothing about unicycles.  It is the selection method; the candidate
library (physically derived columns) lives in :mod:`euc_sim.diagnosis.pipeline`, in the
spirit of PySINDy's split between a feature library and an optimiser.

The model of a residual y (length n) is::

    y(h) = Σ_{c ∈ S} X_c θ_c + e,

where ``y(h)`` depends on a scalar nuisance parameter ``h`` (the rider's centre-of-
gravity height in euc-sim) that is re-identified for every candidate set S by a
bounded 1-D search with θ profiled out by linear least squares, each candidate ``c``
is a named group of one or more columns ``X_c`` (n × k_c), and e is a residual that
is *not* white: it has been through a smoothing filter, so successive samples are
strongly correlated.  Three consequences are built in:

- the information criterion (BIC) counts an *effective* number of samples
  n_eff = n / τ_int, τ_int the integrated autocorrelation time of the residual;
- held-out validation is blocked in time (contiguous blocks of
  :data:`BLOCK_LENGTH` s dealt to the folds in turn, with a guard gap so the filter
  does not leak the held-out blocks into the training set);
- standard errors come from a cluster ("blocked residuals") sandwich covariance.

Forward stepwise selection keeps the history of every step (all trials, their BIC
and held-out RMSE, why the best one was or was not accepted).

Public functions
----------------
:func:`fit_set`, :func:`heldout_rmse`, :func:`covariance`, :func:`bic`,
:func:`forward_select`, :func:`find_aliases`, :func:`generic_gain`,
:func:`sinusoid_basis`, :func:`correlation_time`, :func:`time_blocks`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import minimize_scalar

__all__ = ["SelectionError", "Problem", "Fit", "Step", "Selection", "time_blocks",
           "correlation_time", "fit_set", "heldout_rmse", "covariance", "bic", "forward_select",
           "find_aliases", "generic_gain", "sinusoid_basis", "BLOCK_LENGTH"]


class SelectionError(ValueError):
    """Invalid input to the selection; the message names the argument."""


@dataclass(frozen=True)
class Problem:
    """A residual, its nuisance parameter and the named candidate terms.

    Attributes
    ----------
    target : callable
        ``target(h) -> y``, the residual (shape (n,)) for nuisance value ``h``.
    candidates : mapping of str to numpy.ndarray
        Named candidate groups, each (n, k) with k ≥ 1 (or (n,) for one column).
    time : numpy.ndarray
        (n,) time of each residual sample, s; samples may repeat a time (stacked
        residuals), blocking is by time.
    bounds : tuple of float
        Search interval of the nuisance parameter.
    validity : mapping of str to callable, optional
        ``validity[name](theta) -> None | str``: a reason to refuse the candidate
        with coefficients ``theta`` (a wrong sign, a magnitude out of physics).
    weights : numpy.ndarray, optional
        (n,) non-negative weights of the residual samples (default 1).
    """

    target: Callable[[float], np.ndarray]
    candidates: Mapping[str, np.ndarray]
    time: np.ndarray
    bounds: tuple[float, float]
    validity: Mapping[str, Callable[[np.ndarray], str | None]] = field(default_factory=dict)
    weights: np.ndarray | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.time, dtype=float)
        if t.ndim != 1 or t.size < 10 or not np.all(np.isfinite(t)):
            raise SelectionError(f"time must be a finite 1-D array of at least 10 samples, got shape {t.shape}")
        lo, hi = self.bounds
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise SelectionError(f"bounds must be finite with lo < hi, got {self.bounds!r}")
        cols = {}
        for name, X in self.candidates.items():
            X = np.asarray(X, dtype=float)
            X = X[:, None] if X.ndim == 1 else X
            if X.shape[0] != t.size or X.ndim != 2:
                raise SelectionError(
                    f"candidate {name!r} must have {t.size} rows, got shape {X.shape}")
            if not np.all(np.isfinite(X)):
                raise SelectionError(f"candidate {name!r} has non-finite values")
            cols[name] = X
        object.__setattr__(self, "candidates", cols)
        object.__setattr__(self, "time", t)
        if self.weights is not None:
            w = np.asarray(self.weights, dtype=float)
            if w.shape != t.shape or np.any(w < 0) or not np.all(np.isfinite(w)):
                raise SelectionError(f"weights must be {t.shape} non-negative, got shape {w.shape}")
            object.__setattr__(self, "weights", w)

    @property
    def n(self) -> int:
        return int(self.time.size)

    def design(self, names: Sequence[str]) -> np.ndarray:
        """Columns of the named candidates side by side, (n, Σk)."""
        if not names:
            return np.zeros((self.n, 0))
        return np.hstack([self.candidates[c] for c in names])

    def y(self, h: float) -> np.ndarray:
        y = np.asarray(self.target(h), dtype=float)
        if y.shape != (self.n,):
            raise SelectionError(f"target(h) must return shape ({self.n},), got {y.shape}")
        return y


@dataclass(frozen=True)
class Fit:
    """A least-squares fit of one candidate set with the nuisance profiled.

    Attributes
    ----------
    names : tuple of str
    h : float
        Nuisance parameter at the optimum.
    theta : dict of str to numpy.ndarray
        Coefficients per candidate.
    rss : float
        Weighted residual sum of squares on the fitted samples.
    n : int
        Samples fitted.
    """

    names: tuple[str, ...]
    h: float
    theta: dict[str, np.ndarray]
    rss: float
    n: int

    @property
    def rmse(self) -> float:
        return float(np.sqrt(self.rss / max(self.n, 1)))

    def coef_vector(self) -> np.ndarray:
        if not self.names:
            return np.zeros(0)
        return np.concatenate([self.theta[c] for c in self.names])


def time_blocks(time: np.ndarray, n_blocks: int) -> np.ndarray:
    """Index 0..n_blocks-1 of the contiguous time block of each sample.

    Raises
    ------
    SelectionError
        when ``n_blocks`` < 2.
    """
    if n_blocks < 2:
        raise SelectionError(f"n_blocks must be at least 2, got {n_blocks}")
    t = np.asarray(time, dtype=float)
    t0, t1 = t.min(), t.max()
    b = np.floor((t - t0) / (t1 - t0 + 1e-12) * n_blocks).astype(int)
    return np.clip(b, 0, n_blocks - 1)


def correlation_time(e: np.ndarray, max_lag: int | None = None) -> float:
    """Integrated autocorrelation time of a residual, in samples (≥ 1).

    τ_int = 1 + 2 Σ_k ρ_k summed up to the first non-positive ρ_k (Geyer's initial
    positive sequence, simplified).  A white residual gives about 1.
    """
    e = np.asarray(e, dtype=float)
    e = e - e.mean()
    n = e.size
    max_lag = min(n // 4, max_lag or n // 4)
    if n < 8 or not np.any(e):
        return 1.0
    f = np.fft.rfft(e, 2 * n)
    ac = np.fft.irfft(f * np.conj(f))[: max_lag + 1]
    rho = ac / ac[0]
    tau = 1.0
    for k in range(1, max_lag + 1):
        if rho[k] <= 0:
            break
        tau += 2.0 * rho[k]
    return float(max(tau, 1.0))


def _profile(problem: Problem, X: np.ndarray, idx: np.ndarray, n_grid: int = 13):
    """Minimise over h the weighted RSS of y(h) − Xθ on samples idx; returns (h, θ, rss)."""
    w = np.ones(problem.n) if problem.weights is None else problem.weights
    sw = np.sqrt(w[idx])
    Xi = X[idx] * sw[:, None]
    if Xi.shape[1]:
        Qm, Rm = np.linalg.qr(Xi)
    else:
        Qm = Rm = None

    def rss(h: float) -> float:
        yi = problem.y(h)[idx] * sw
        if Qm is not None:
            yi = yi - Qm @ (Qm.T @ yi)
        return float(yi @ yi)

    lo, hi = problem.bounds
    grid = np.linspace(lo, hi, n_grid)
    vals = np.array([rss(h) for h in grid])
    k = int(np.argmin(vals))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, n_grid - 1)]
    res = minimize_scalar(rss, bounds=(a, b), method="bounded", options={"xatol": 1e-5})
    h = float(res.x) if res.fun <= vals[k] else float(grid[k])
    yi = problem.y(h)[idx] * sw
    if Qm is not None:
        theta = np.linalg.solve(Rm, Qm.T @ yi) if np.all(np.abs(np.diag(Rm)) > 1e-12) else \
            np.linalg.lstsq(Xi, yi, rcond=None)[0]
    else:
        theta = np.zeros(0)
    e = yi - Xi @ theta
    return h, theta, float(e @ e)


def _split_theta(problem: Problem, names: Sequence[str], theta: np.ndarray) -> dict[str, np.ndarray]:
    out, i = {}, 0
    for c in names:
        k = problem.candidates[c].shape[1]
        out[c] = theta[i:i + k].copy()
        i += k
    return out


def fit_set(problem: Problem, names: Sequence[str], idx: np.ndarray | None = None) -> Fit:
    """Fit the candidate set ``names`` jointly with the nuisance parameter.

    Parameters
    ----------
    problem : Problem
    names : sequence of str
        Candidates to include (may be empty: the nuisance alone).
    idx : numpy.ndarray of int, optional
        Samples to fit (all by default).

    Returns
    -------
    Fit
    """
    names = tuple(names)
    unknown = [c for c in names if c not in problem.candidates]
    if unknown:
        raise SelectionError(f"unknown candidate {unknown[0]!r}; expected one of {', '.join(problem.candidates)}")
    idx = np.arange(problem.n) if idx is None else np.asarray(idx)
    X = problem.design(names)
    h, theta, rss = _profile(problem, X, idx)
    return Fit(names, h, _split_theta(problem, names, theta), rss, int(idx.size))


#: Length of the contiguous held-out blocks, s (several correlation times of the
#: filtered residual).
BLOCK_LENGTH = 2.0


def _train_test(problem: Problem, n_blocks: int, guard: float, block: float = BLOCK_LENGTH):
    """Folds of blocked cross-validation.

    The record is cut into contiguous blocks of ``block`` s; block i belongs to fold
    i mod ``n_blocks``, so every fold holds out blocks spread over the whole maneuver
    (a maneuver is not stationary: holding out its whole first fifth would test
    extrapolation to speeds the training never saw).  Training samples closer than
    ``guard`` s to any held-out sample are dropped, so the filter does not leak.
    """
    t = problem.time
    span = t.max() - t.min()
    G = max(n_blocks, int(np.floor(span / block)))
    blk = time_blocks(t, G)
    folds = []
    order = np.argsort(t, kind="stable")
    ts = t[order]
    for f in range(n_blocks):
        test_mask = (blk % n_blocks) == f
        test = np.flatnonzero(test_mask)
        # distance of every sample to the nearest held-out sample, via the sorted times
        tt = np.unique(t[test])
        pos = np.searchsorted(tt, ts)
        left = np.abs(ts - tt[np.clip(pos - 1, 0, tt.size - 1)])
        right = np.abs(tt[np.clip(pos, 0, tt.size - 1)] - ts)
        near = np.empty(t.size, bool)
        near[order] = np.minimum(left, right) <= guard
        train = np.flatnonzero(~test_mask & ~near)
        folds.append((train, test))
    return folds


def heldout_rmse(problem: Problem, names: Sequence[str], n_blocks: int = 10,
                 guard: float = 0.5, extra: Callable | None = None) -> float:
    """Held-out RMSE of a candidate set, blocked in time, h re-identified per fold.

    Parameters
    ----------
    problem : Problem
    names : sequence of str
    n_blocks : int
        Folds: contiguous blocks of :data:`BLOCK_LENGTH` s are dealt to the folds in
        turn; each fold is held out once.
    guard : float
        Time, s, dropped from the training set on each side of the held-out block
        (the smoothing filter's reach).
    extra : callable, optional
        ``extra(train_idx, train_residual, h) -> (n, k) columns`` built from the
        training samples only (a generic basis, see :func:`generic_gain`); added to
        the design of that fold.

    Returns
    -------
    float
        sqrt(Σ e² / Σ n) over the held-out samples, the residual's unit.
    """
    names = tuple(names)
    X = problem.design(names)
    w = np.ones(problem.n) if problem.weights is None else problem.weights
    sse, cnt = 0.0, 0
    for train, test in _train_test(problem, n_blocks, guard):
        if train.size < 10:
            raise SelectionError(f"n_blocks={n_blocks} and guard={guard} leave a fold without training samples")
        h, theta, _ = _profile(problem, X, train)
        Xf = X
        if extra is not None:
            y = problem.y(h)
            r_train = y[train] - X[train] @ theta
            E = np.asarray(extra(train, r_train, h), dtype=float)
            if E.size:
                Xf = np.hstack([X, E])
                h, theta, _ = _profile(problem, Xf, train)
        e = problem.y(h)[test] - Xf[test] @ theta
        sse += float(np.sum(w[test] * e * e))
        cnt += int(test.size)
    return float(np.sqrt(sse / cnt))


def _jacobian_h(problem: Problem, h: float, step: float = 1e-4) -> np.ndarray:
    return (problem.y(h + step) - problem.y(h - step)) / (2 * step)


def covariance(problem: Problem, fit: Fit, cluster: float) -> tuple[np.ndarray, float]:
    """Covariance of (θ, h): cluster-robust, never below the autocorrelation-scaled one.

    The residual is linearised in h at the optimum: J = [X, −∂y/∂h]; the sandwich
    (JᵀJ)⁻¹ (Σ_b J_bᵀ e_b e_bᵀ J_b) (JᵀJ)⁻¹ · G/(G−1) over G blocks.  With G ≈ 10
    blocks the sandwich is biased low, most for a column that varies slowly from
    block to block (the 12 s h drift: on null recordings it gave |θ|/se up to 14).
    So each parameter's variance is raised, where lower, to the conventional one
    s² (JᵀJ)⁻¹ scaled by the residual's integrated correlation time τ_int; the
    sandwich's correlations are kept.  This is the rule "the larger of the robust and
    the conventional standard error" (Angrist & Pischke, *Mostly Harmless
    Econometrics*, 2009, §8.2.3).  In the blind study it lifted the 95 % intervals'
    coverage from 84–88 % to 96–99 %.

    Returns
    -------
    cov : numpy.ndarray
        ((Σk + 1) × (Σk + 1)); the last row/column is h.
    dof : float
        G − 1, for a Student-t quantile.
    """
    X = problem.design(fit.names)
    y = problem.y(fit.h)
    e = y - X @ fit.coef_vector()
    J = np.hstack([X, -_jacobian_h(problem, fit.h)[:, None]])
    w = np.ones(problem.n) if problem.weights is None else problem.weights
    J = J * np.sqrt(w)[:, None]
    e = e * np.sqrt(w)
    span = problem.time.max() - problem.time.min()
    G = int(max(2, np.floor(span / max(cluster, 1e-9))))
    blk = time_blocks(problem.time, G)
    A = J.T @ J
    try:
        Ainv = np.linalg.inv(A)
    except np.linalg.LinAlgError:
        Ainv = np.linalg.pinv(A)
    S = np.zeros_like(A)
    for b in range(G):
        sel = blk == b
        g = J[sel].T @ e[sel]
        S += np.outer(g, g)
    robust = Ainv @ S @ Ainv * G / (G - 1)
    conventional = Ainv * float(e @ e) / max(e.size - J.shape[1], 1) * correlation_time(e)
    se_r = np.sqrt(np.maximum(np.diag(robust), 1e-300))
    raise_by = np.maximum(np.sqrt(np.maximum(np.diag(conventional), 0.0)) / se_r, 1.0)
    return robust * np.outer(raise_by, raise_by), float(G - 1)


@dataclass(frozen=True)
class Step:
    """One step of forward selection: every trial and the decision."""

    step: int
    base: tuple[str, ...]
    trials: list[dict]
    chosen: str | None
    accepted: bool
    reason: str


@dataclass(frozen=True)
class Selection:
    """Outcome of :func:`forward_select`.

    Attributes
    ----------
    selected : tuple of str
        Accepted candidates in the order of acceptance (strongest first).
    fit : Fit
        Final fit on all samples.
    nominal : Fit
        Fit of the nuisance alone.
    cv_nominal, cv_final : float
        Held-out RMSE of the nuisance-only model and of the final set.
    cv_path : list of float
        Held-out RMSE after each accepted candidate.
    n_eff : float
        Effective sample count used by the BIC.
    tau_int : float
        Correlation time of the nominal residual, samples.
    history : list of Step
    """

    selected: tuple[str, ...]
    fit: Fit
    nominal: Fit
    cv_nominal: float
    cv_final: float
    cv_path: list[float]
    n_eff: float
    tau_int: float
    history: list[Step]


def bic(rss: float, n: int, n_eff: float, n_params: int) -> float:
    """BIC with an effective sample count: n_eff ln(RSS/n) + p ln(n_eff)."""
    return float(n_eff * np.log(max(rss, 1e-300) / n) + n_params * np.log(n_eff))


def forward_select(problem: Problem, *, n_blocks: int = 10, guard: float = 0.5,
                   min_bic_drop: float = 10.0, min_cv_gain: float = 0.10,
                   min_t: float = 4.0, cluster: float = 2.0, max_terms: int = 3,
                   allowed: Sequence[str] | None = None, n_eff: float | None = None,
                   progress: Callable[[str], None] | None = None) -> Selection:
    """Forward stepwise selection with blocked held-out validation and BIC.

    At each step every remaining candidate is added in turn to the accepted set, the
    nuisance re-identified, and BIC (with n_eff) and the held-out RMSE computed.
    The candidate with the lowest BIC is accepted when all of these hold:

    - BIC drops by at least ``min_bic_drop``;
    - the held-out RMSE drops by at least the fraction ``min_cv_gain``;
    - every coefficient of the new group has |θ|/se ≥ ``min_t`` (cluster sandwich);
    - ``problem.validity[name](θ)`` has no objection.

    Otherwise selection stops.

    Parameters
    ----------
    problem : Problem
    n_blocks, guard : int, float
        Held-out validation (see :func:`heldout_rmse`).
    min_bic_drop, min_cv_gain, min_t : float
        Acceptance thresholds (dimensionless).
    cluster : float
        Cluster length for standard errors, s.
    max_terms : int
        At most this many candidates are accepted.
    allowed : sequence of str, optional
        Candidates eligible (all by default).
    n_eff : float, optional
        Effective sample count for the BIC; by default n / τ_int of the nominal
        residual (which overstates the correlation when an effect dominates it:
        prefer τ_int of a noise-only residual, as :mod:`euc_sim.diagnosis.pipeline` does).

    Returns
    -------
    Selection
    """
    say = progress or (lambda s: None)
    pool = [c for c in (allowed if allowed is not None else problem.candidates)]
    nominal = fit_set(problem, ())
    y0 = problem.y(nominal.h)
    tau = correlation_time(y0)
    n_eff = max(problem.n / tau, 5.0) if n_eff is None else float(n_eff)
    cv_nom = heldout_rmse(problem, (), n_blocks, guard)
    current, cur_fit, cur_cv = (), nominal, cv_nom
    cur_bic = bic(nominal.rss, nominal.n, n_eff, 1)
    history: list[Step] = [Step(0, (), [{"name": None, "bic": cur_bic, "cv_rmse": cv_nom,
                                         "rmse": nominal.rmse, "h": nominal.h}], None, True,
                                "nominal model: h only")]
    cv_path: list[float] = []
    for step in range(1, max_terms + 1):
        remaining = [c for c in pool if c not in current]
        if not remaining:
            break
        trials = []
        for c in remaining:
            f = fit_set(problem, current + (c,))
            k = sum(problem.candidates[n].shape[1] for n in f.names) + 1
            b = bic(f.rss, f.n, n_eff, k)
            cv = heldout_rmse(problem, f.names, n_blocks, guard)
            trials.append({"name": c, "bic": b, "cv_rmse": cv, "rmse": f.rmse, "h": f.h,
                           "theta": f.theta[c].tolist(), "_fit": f})
            say(f"step {step}: {c}: BIC {b:.1f}, held-out RMSE {cv:.3f}")
        trials.sort(key=lambda d: d["bic"])
        fits = {d["name"]: d.pop("_fit") for d in trials}
        accepted, chosen, reason, f, best = False, None, "no candidate left", None, None
        refused = []
        for d in trials:
            f = fits[d["name"]]
            reasons = _judge(problem, f, d, cur_bic, cur_cv, min_bic_drop, min_cv_gain,
                             min_t, cluster)
            if not reasons:
                accepted, chosen, best = True, d["name"], d
                break
            if d["bic"] > cur_bic - min_bic_drop or d.get("cv_gain", 0.0) < min_cv_gain:
                chosen, best = d["name"], d          # the best plausible one is not good enough
                refused.append(f"{d['name']}: " + "; ".join(reasons))
                break
            refused.append(f"{d['name']}: " + "; ".join(reasons))   # refused on physics: try the next
        reason = "accepted" + (f" (refused before it: {' | '.join(refused)})" if refused else "") \
            if accepted else " | ".join(refused) or reason
        history.append(Step(step, current, trials, chosen, accepted, reason))
        if not accepted:
            break
        current, cur_fit, cur_cv, cur_bic = f.names, f, best["cv_rmse"], best["bic"]
        pool = [c for c in pool if c not in refused_names(refused)]
        cv_path.append(cur_cv)
    return Selection(current, cur_fit, nominal, cv_nom, cur_cv, cv_path, n_eff, tau, history)


def refused_names(refused: list[str]) -> set[str]:
    """Names of candidates refused on physics in one step (not offered again)."""
    return {r.split(":", 1)[0] for r in refused}


def _judge(problem: Problem, f: Fit, d: dict, cur_bic: float, cur_cv: float,
           min_bic_drop: float, min_cv_gain: float, min_t: float, cluster: float) -> list[str]:
    """Reasons to refuse the trial ``d`` (fit ``f``); empty when it is accepted."""
    name = d["name"]
    cov, _ = covariance(problem, f, cluster)
    theta = f.coef_vector()
    k_new = problem.candidates[name].shape[1]
    se = np.sqrt(np.maximum(np.diag(cov)[:-1], 1e-300))
    t_new = float(np.min(np.abs(theta[-k_new:]) / se[-k_new:]))
    if k_new > 1:   # a group: its joint size (Wald), as an equivalent |t|
        i0 = len(theta) - k_new
        Cg, tg = cov[i0:len(theta), i0:len(theta)], theta[-k_new:]
        try:
            wald = float(tg @ np.linalg.solve(Cg, tg))
        except np.linalg.LinAlgError:
            wald = 0.0
        t_new = float(np.sqrt(max(wald - (k_new - 1), 0.0)))
    d["t"] = t_new
    d["cv_gain"] = 1.0 - d["cv_rmse"] / cur_cv
    reasons = []
    if cur_bic - d["bic"] < min_bic_drop:
        reasons.append(f"BIC drop {cur_bic - d['bic']:.1f} < {min_bic_drop:g}")
    if d["cv_gain"] < min_cv_gain:
        reasons.append(f"held-out RMSE gain {100 * d['cv_gain']:.1f}% < {100 * min_cv_gain:.0f}%")
    if t_new < min_t:
        reasons.append(f"|θ|/se {t_new:.1f} < {min_t:g}")
    check = problem.validity.get(name)
    why = check(f.theta[name]) if check else None
    if why:
        reasons.append(why)
    return reasons


def find_aliases(problem: Problem, selected: Sequence[str], name: str,
                 candidates: Sequence[str], n_eff: float, max_bic: float = 10.0,
                 cosine: float = 0.95) -> list[str]:
    """Candidates this recording cannot tell apart from ``name``.

    Candidate ``a`` is an alias of ``name`` when, in the accepted set with ``name``
    swapped for ``a`` (h re-identified), the fit is physically valid and its BIC is
    within ``max_bic`` of the accepted set's (the data do not decisively prefer
    ``name``), or when the two single columns have |cosine| ≥ ``cosine``.

    Parameters
    ----------
    problem : Problem
    selected : sequence of str
        The accepted set, containing ``name``.
    name : str
    candidates : sequence of str
        Candidates to test.
    n_eff : float
        Effective sample count of the BIC.
    max_bic, cosine : float

    Returns
    -------
    list of str
    """
    selected = tuple(selected)
    without = tuple(c for c in selected if c != name)
    f_with = fit_set(problem, selected)
    out = []
    for a in candidates:
        if a == name or a in selected:
            continue
        Xa, Xn = problem.candidates[a], problem.candidates[name]
        cos = 0.0
        if Xa.shape[1] == 1 and Xn.shape[1] == 1:
            na, nn = np.linalg.norm(Xa), np.linalg.norm(Xn)
            cos = float(abs(Xa[:, 0] @ Xn[:, 0]) / (na * nn)) if na > 0 and nn > 0 else 0.0
        f_a = fit_set(problem, without + (a,))
        check = problem.validity.get(a)
        valid = not (check and check(f_a.theta[a]))
        k_extra = Xa.shape[1] - Xn.shape[1]
        d_bic = n_eff * np.log(max(f_a.rss, 1e-300) / max(f_with.rss, 1e-300)) + k_extra * np.log(n_eff)
        if valid and (cos >= cosine or d_bic < max_bic):
            out.append(a)
    return out


def sinusoid_basis(time: np.ndarray, fmin: float = 0.1, fmax: float = 3.0, n_freq: int = 300):
    """A generic basis builder: the sinusoid that best fits the training residual.

    Returns a function usable as ``extra`` in :func:`heldout_rmse`: it scans
    frequencies in [fmin, fmax] Hz on the training samples (least squares on sin and
    cos, so gaps are handled), and returns the two full-length columns at the best
    frequency.  A periodic disturbance extrapolates to the held-out block; filtered
    noise does not.
    """
    t = np.asarray(time, dtype=float)
    freqs = np.linspace(fmin, fmax, n_freq)

    def extra(train, r_train, h):
        tt = t[train]
        best, fb = -1.0, freqs[0]
        for f in freqs:
            s, c = np.sin(2 * np.pi * f * tt), np.cos(2 * np.pi * f * tt)
            A = np.column_stack([s, c])
            coef, *_ = np.linalg.lstsq(A, r_train, rcond=None)
            gain = float(r_train @ (A @ coef))
            if gain > best:
                best, fb = gain, f
        return np.column_stack([np.sin(2 * np.pi * fb * t), np.cos(2 * np.pi * fb * t)])

    return extra


def generic_gain(problem: Problem, selected: Sequence[str], extra: Callable,
                 n_blocks: int = 10, guard: float = 0.5) -> tuple[float, float]:
    """Held-out RMSE without and with a generic basis on top of ``selected``.

    Returns
    -------
    (cv_without, cv_with) : tuple of float
    """
    a = heldout_rmse(problem, selected, n_blocks, guard)
    b = heldout_rmse(problem, selected, n_blocks, guard, extra=extra)
    return a, b
