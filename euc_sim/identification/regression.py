"""Least squares with a nuisance parameter, blocked in time: the regression behind selection.

A residual y (length n) is modelled as y(h) = Σ_{c ∈ S} X_c θ_c + e, h a scalar nuisance
(the rider's CoG height) re-identified for every candidate set S by a bounded 1-D search
with θ profiled out, each candidate ``c`` a named group of columns X_c (n × k_c).  e is
filtered, hence correlated: held-out validation is blocked in time with a guard gap, and
standard errors come from a cluster sandwich covariance (the BIC's effective sample count
is in :mod:`euc_sim.identification.selection`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from euc_sim.errors import InputError
from euc_sim.stats import interleaved_folds, span_blocks

__all__ = ["SelectionError", "Problem", "Adapted", "Fit", "correlation_time", "fit_set",
           "heldout_rmse", "covariance", "BLOCK_LENGTH", "HELDOUT_FOLDS", "GUARD", "CLUSTER"]


class SelectionError(InputError):
    """Invalid input to the selection; the message names the argument."""


@dataclass(frozen=True)
class Problem:
    """A residual, its nuisance parameter and the named candidate terms.

    Attributes
    ----------
    target : callable
        ``target(h) -> y``, shape (n,).
    candidates : mapping of str to numpy.ndarray
        Named candidate groups, each (n, k) or (n,).
    time : numpy.ndarray
        (n,) time of each sample, s (may repeat for stacked residuals); blocking is by time.
    bounds : tuple of float
        Search interval of h.
    validity : mapping of str to callable, optional
        ``validity[name](theta) -> None | str``: a reason to refuse the estimate.
    shape_params : mapping of str to int, optional
        Parameters the data chose for a candidate before the fit, counted in the BIC.
    adaptive : mapping of str to callable, optional
        ``adaptive[name](others) -> Adapted``: columns chosen given the set's other members
        (a sorted tuple of names); replaces the candidate's other entries inside a set.
    """

    target: Callable[[float], np.ndarray]
    candidates: Mapping[str, np.ndarray]
    time: np.ndarray
    bounds: tuple[float, float]
    validity: Mapping[str, Callable[[np.ndarray], str | None]] = field(default_factory=dict)
    shape_params: Mapping[str, int] = field(default_factory=dict)
    adaptive: Mapping[str, Callable[[tuple], "Adapted"]] = field(default_factory=dict)

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

    @property
    def n(self) -> int:
        return int(self.time.size)

    def adapted(self, name: str, names: Sequence[str]) -> "Adapted":
        """Candidate ``name`` inside the set ``names`` (through its adaptive hook where it has one)."""
        if name in self.adaptive:
            a = self.adaptive[name](tuple(sorted(c for c in names if c != name)))
            X = np.asarray(a.columns, dtype=float)
            X = X[:, None] if X.ndim == 1 else X
            if X.shape[0] != self.n or not np.all(np.isfinite(X)):
                raise SelectionError(f"adaptive candidate {name!r} must give {self.n} finite rows, got {X.shape}")
            return Adapted(X, a.n_shape, a.check)
        return Adapted(self.candidates[name], self.shape_params.get(name, 0), self.validity.get(name))

    def columns(self, name: str, names: Sequence[str] = ()) -> np.ndarray:
        """Columns of candidate ``name`` inside the set ``names`` (n, k)."""
        return self.adapted(name, names).columns

    def design(self, names: Sequence[str]) -> np.ndarray:
        """Columns of the named candidates side by side, (n, Σk)."""
        if not names:
            return np.zeros((self.n, 0))
        return np.hstack([self.columns(c, names) for c in names])

    def frozen(self, names: Sequence[str]) -> "Problem":
        """The problem with every adaptive candidate fixed as it is (or would be) inside the set ``names``."""
        if not self.adaptive:
            return self
        cands, shape, valid = dict(self.candidates), dict(self.shape_params), dict(self.validity)
        for c in self.adaptive:
            a = self.adapted(c, tuple(names) + ((c,) if c not in names else ()))
            cands[c], shape[c] = a.columns, a.n_shape
            if a.check is not None:
                valid[c] = a.check
        return Problem(self.target, cands, self.time, self.bounds, valid, shape)

    def y(self, h: float) -> np.ndarray:
        y = np.asarray(self.target(h), dtype=float)
        if y.shape != (self.n,):
            raise SelectionError(f"target(h) must return shape ({self.n},), got {y.shape}")
        return y


@dataclass(frozen=True)
class Adapted:
    """An adaptive candidate inside one set: columns (n, k), parameters chosen (for the BIC), validity check."""

    columns: np.ndarray
    n_shape: int = 0
    check: Callable[[np.ndarray], str | None] | None = None


@dataclass(frozen=True)
class Fit:
    """A least-squares fit of one candidate set with h profiled: ``names``, ``h``, ``theta`` per candidate,
    ``rss``, ``n`` samples."""

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


def correlation_time(e: np.ndarray) -> float:
    """Integrated autocorrelation time τ_int = 1 + 2 Σ ρ_k up to the first ρ_k ≤ 0 (lags up to n/4), samples (≥ 1)."""
    e = np.asarray(e, dtype=float)
    e = e - e.mean()
    n = e.size
    max_lag = n // 4
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
    """Minimise over h the RSS of y(h) − Xθ on samples idx; returns (h, θ, rss)."""
    Xi = X[idx]
    if Xi.shape[1]:
        Qm, Rm = np.linalg.qr(Xi)
    else:
        Qm = Rm = None

    def rss(h: float) -> float:
        yi = problem.y(h)[idx]
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
    yi = problem.y(h)[idx]
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
        k = problem.columns(c, names).shape[1]
        out[c] = theta[i:i + k].copy()
        i += k
    return out


def fit_set(problem: Problem, names: Sequence[str]) -> Fit:
    """Fit the candidate set ``names`` (may be empty) jointly with h, on all samples."""
    names = tuple(names)
    unknown = [c for c in names if c not in problem.candidates]
    if unknown:
        raise SelectionError(f"unknown candidate {unknown[0]!r}; expected one of {', '.join(problem.candidates)}")
    idx = np.arange(problem.n)
    X = problem.design(names)
    h, theta, rss = _profile(problem, X, idx)
    return Fit(names, h, _split_theta(problem, names, theta), rss, int(idx.size))


#: Length of the contiguous held-out blocks, s (several correlation times of the residual).
BLOCK_LENGTH = 2.0
#: Folds of the held-out validation: blocks of :data:`BLOCK_LENGTH` s dealt to them in turn.
HELDOUT_FOLDS = 10
#: Time dropped from training on each side of a held-out block, s.
GUARD = 0.5
#: Cluster length of the sandwich covariance, s.
CLUSTER = 2.0


def heldout_rmse(problem: Problem, names: Sequence[str], extra: Callable | None = None) -> float:
    """Held-out RMSE of a candidate set, blocked in time (:data:`HELDOUT_FOLDS`, :data:`GUARD`), h re-identified
    per fold.

    Parameters
    ----------
    problem : Problem
    names : sequence of str
    extra : callable, optional
        ``extra(train_idx, train_residual, h) -> (n, k)`` columns built from the training
        samples only, added to that fold's design (:func:`~euc_sim.identification.selection.generic_gain`).

    Returns
    -------
    float
        sqrt(Σ e² / n) over the held-out samples, the residual's unit.
    """
    names = tuple(names)
    X = problem.design(names)
    sse, cnt = 0.0, 0
    for train, test in interleaved_folds(problem.time, HELDOUT_FOLDS, BLOCK_LENGTH, GUARD):
        if train.size < 10:
            raise SelectionError(f"{HELDOUT_FOLDS} folds and a guard of {GUARD} s leave a fold without training "
                                 f"samples")
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
        sse += float(np.sum(e * e))
        cnt += int(test.size)
    return float(np.sqrt(sse / cnt))


def covariance(problem: Problem, fit: Fit) -> tuple[np.ndarray, float]:
    """Covariance of (θ, h): the cluster sandwich, each variance raised to at least the conventional one.

    J = [X, −∂y/∂h] at the optimum; robust = (JᵀJ)⁻¹ (Σ_b J_bᵀ e_b e_bᵀ J_b) (JᵀJ)⁻¹ · G/(G−1)
    over G clusters of :data:`CLUSTER` s; each standard error is raised, where lower, to that of
    s² (JᵀJ)⁻¹ τ_int, keeping the sandwich's correlations (Angrist & Pischke 2009, §8.2.3:
    with G ≈ 10 the sandwich is biased low for slowly varying columns).

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
    dh = 1e-4
    J = np.hstack([X, -((problem.y(fit.h + dh) - problem.y(fit.h - dh)) / (2 * dh))[:, None]])
    span = problem.time.max() - problem.time.min()
    G = int(max(2, np.floor(span / CLUSTER)))
    blk = span_blocks(problem.time, G)
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
