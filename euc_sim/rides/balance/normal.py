"""The balance's cost as a quadratic form: fits from the Gram matrices of its basis.

The prediction :meth:`~euc_sim.rides.balance.design.Design.predict` is

    P̂ = Σ_j θ_j·(L₂ − τ_I·L₂′ + τ_I²·L₂″)[c_j] + P₀,  θ_inertia = 1,

so the weighted residual w·(P − P̂) is ``Z @ v``: ``Z`` the design's
:attr:`~euc_sim.rides.balance.design.Design.basis` and ``v`` the coefficients, linear in θ for a given
τ_I.  Every fit then needs only ``ZᵀZ`` summed over its rows: a fold leaves out its
blocks' Gram matrices, a wild bootstrap replicate flips the sign of its blocks'
residual cross-products.  At a given lag the fit is a convex quadratic problem in the
bounds' box, solved exactly (:func:`box_qp`); the lag is searched on its profile cost
(:func:`solve_grams`), for a whole batch of Grams at once.
"""

from __future__ import annotations

from itertools import product
from types import SimpleNamespace
from typing import Sequence

import numpy as np

from euc_sim.rides.balance.design import BOUNDS, CANDIDATES, role_index, term_role
from euc_sim.simulation.effects import RECORDS

__all__ = ["coefficients", "solve_gram", "solve_grams", "box_qp", "scale", "bounds", "snap_to_bounds"]

#: Slots of one regressor in the basis: L₂[c], L₂′[c], L₂″[c].
_SLOTS = 3


def coefficients(columns: Sequence[str], names: Sequence[str], theta: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """``v`` with residual = Z·v, and ∂v/∂θ (len(v) × len(names)), at ``theta``.

    Parameters
    ----------
    columns : sequence of str
        :attr:`~euc_sim.rides.balance.design.Basis.columns`.
    names : sequence of str
        Fitted parameters (keys of :data:`CANDIDATES`).
    theta : numpy.ndarray
        Their values.
    """
    names = list(names)
    lag = role_index(names, "lag")
    tau = float(theta[lag]) if lag is not None else 0.0
    linear = [j for j in range(len(names)) if j != lag]
    v0, D = _affine(columns, [names[j] for j in linear], np.array([tau]))
    v = v0[0] + D[0] @ np.asarray(theta, float)[linear]
    dv = np.zeros((len(v), len(names)))
    dv[:, linear] = D[0]
    if lag is not None:                                  # d/dτ of −θ_c·(L₂ − τ·L₂′ + τ²·L₂″)[c]
        scaled = [("inertia", 1.0)] + [(CANDIDATES[names[j]][3], float(theta[j])) for j in linear
                                       if CANDIDATES[names[j]][3] is not None]
        for col, th in scaled:
            i = _SLOTS * columns.index(col)
            dv[i + 1, lag], dv[i + 2, lag] = th, -2.0 * tau * th
    return v, dv

def scale(names: Sequence[str]) -> np.ndarray:
    """Typical size of each parameter: the fit's variables are the parameters over it."""
    return np.array([RECORDS.get(n).balance.scale if n in CANDIDATES else 0.1 for n in names])


def bounds(names: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of ``names`` (:data:`BOUNDS`; unbounded where absent)."""
    lo = np.array([BOUNDS.get(n, (-np.inf, np.inf))[0] for n in names])
    hi = np.array([BOUNDS.get(n, (-np.inf, np.inf))[1] for n in names])
    return lo, hi


#: A parameter within this fraction of its typical size from a bound sits on it.
_BOUND_SNAP = 1e-6


def snap_to_bounds(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, size: np.ndarray) -> np.ndarray:
    """``x`` with values within ``_BOUND_SNAP``·size of a bound set exactly on it (a new array).

    A parameter whose optimum is a bound may come back a rounding error away from it
    (the lag's Newton steps); on the bound, the page can say that it sits there.
    """
    x = np.array(x, dtype=float)
    x = np.where(np.abs(x - lo) <= _BOUND_SNAP * size, lo, x)
    return np.where(np.abs(hi - x) <= _BOUND_SNAP * size, hi, x)


def _affine(columns: Sequence[str], linear: Sequence[str], tau: np.ndarray):
    """``v0`` (n, p) and ``D`` (n, p, k) with ``v = v0 + D·θ`` for the linear ``θ`` at lags ``tau`` (n,)."""
    n, p = len(tau), _SLOTS * len(columns) + 2
    filt = np.stack([np.ones(n), -tau, tau ** 2], axis=1)       # L₂ − τ·L₂′ + τ²·L₂″
    v0, D = np.zeros((n, p)), np.zeros((n, p, len(linear)))
    v0[:, -1] = 1.0
    i = _SLOTS * columns.index("inertia")
    v0[:, i:i + _SLOTS] = -filt
    for j, name in enumerate(linear):
        col = CANDIDATES[name][3]
        if col is not None:
            i = _SLOTS * columns.index(col)
            D[:, i:i + _SLOTS, j] = -filt
        elif term_role(name) == "constant":
            D[:, -2, j] = -1.0
    return v0, D


def _pattern_solve(A: np.ndarray, b: np.ndarray, state: np.ndarray, lo: np.ndarray, hi: np.ndarray):
    """x with the rows of ``state`` 0 solving (A·x + b)ᵢ = 0 and the others on their bound (−1 lo, +1 hi)."""
    free = state == 0
    M = np.where(free[:, :, None], A, np.eye(A.shape[-1]))
    rhs = np.where(free, -b, np.where(state < 0, lo, hi))
    try:
        x = np.linalg.solve(M, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:                  # a singular free block: its least-norm point
        x = (np.linalg.pinv(M) @ rhs[..., None])[..., 0]
    return np.where(free, x, rhs)                  # a held variable exactly on its bound


def box_qp(A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """argmin ½·xᵀAx + bᵀx on lo ≤ x ≤ hi, for a batch of small convex problems.

    Block pivoting on the set of variables held on a bound until the set repeats (then the
    KKT conditions hold); a problem that cycles is solved by trying every set (3ᵏ).  ``A``
    (n, k, k) symmetric positive semi-definite, ``b`` (n, k), ``lo``, ``hi`` (k,) finite.
    Returns the (n, k) minimisers and their state (int8: 0 free, −1 lower, +1 upper bound).
    """
    n, k = b.shape
    state = np.zeros((n, k), dtype=np.int8)
    x = np.empty((n, k))
    todo = np.arange(n if k else 0)
    for _ in range(2 * k + 2):
        if not todo.size:
            return x, state
        At, bt, old = A[todo], b[todo], state[todo]
        xs = _pattern_solve(At, bt, old, lo, hi)
        g = np.einsum("nij,nj->ni", At, xs) + bt
        new = np.where((old == 0) & (xs < lo), -1, np.where((old == 0) & (xs > hi), 1, old))
        new = np.where(((old < 0) & (g < 0)) | ((old > 0) & (g > 0)), 0, new).astype(np.int8)
        same = (new == old).all(axis=1)
        x[todo[same]] = xs[same]
        state[todo] = new
        todo = todo[~same]

    patterns = np.array(list(product((-1, 0, 1), repeat=k)), dtype=np.int8)
    span = hi - lo
    for r in todo:
        xs = _pattern_solve(np.broadcast_to(A[r], (len(patterns), k, k)),
                            np.broadcast_to(b[r], (len(patterns), k)), patterns, lo, hi)
        ok = np.all((xs >= lo - 1e-12 * span) & (xs <= hi + 1e-12 * span), axis=1)
        cost = 0.5 * np.einsum("ni,ij,nj->n", xs, A[r], xs) + xs @ b[r]
        best = np.flatnonzero(ok)[np.argmin(cost[ok])]
        x[r], state[r] = np.clip(xs[best], lo, hi), patterns[best]
    return x, state


#: Lags tried on an even grid over the lag's bounds before the Newton steps.
_LAG_GRID = 11
#: The lag's Newton steps stop below this change, s.
_LAG_TOL = 1e-12
#: Most Newton (or bisection) steps on the lag.
_LAG_STEPS = 60


class _Profile:
    """Half the squared residual of a batch of Grams as polynomials (degree 4) in the lag τ,
    ½·(c(τ) + 2·b(τ)ᵀz + zᵀA(τ)z), z the linear parameters over their :func:`scale`.
    """

    def __init__(self, G: np.ndarray, columns: Sequence[str], linear: Sequence[str]):
        self.size = scale(linear)
        lo, hi = bounds(linear)
        self.lo, self.hi = lo / self.size, hi / self.size
        v, D = _affine(columns, linear, np.array([0.0, 1.0, -1.0]))    # v(τ) = V₀ + τV₁ + τ²V₂
        V = np.stack([v[0], 0.5 * (v[1] - v[2]), 0.5 * (v[1] + v[2]) - v[0]])
        D = np.stack([D[0], 0.5 * (D[1] - D[2]), 0.5 * (D[1] + D[2]) - D[0]]) * self.size
        GV, GD = np.einsum("npq,aq->nap", G, V), np.matmul(G[:, None], D[None])
        n, k = len(G), len(linear)
        self.A, self.b, self.c = np.zeros((n, 5, k, k)), np.zeros((n, 5, k)), np.zeros((n, 5))
        for i in range(3):
            for j in range(3):
                self.A[:, i + j] += np.einsum("pk,npj->nkj", D[i], GD[:, j])
                self.b[:, i + j] += np.einsum("pk,np->nk", D[i], GV[:, j])
                self.c[:, i + j] += GV[:, j] @ V[i]

    def at(self, tau: np.ndarray, rows=slice(None), slope: bool = False):
        """Parameters (n, s, k) and cost (n, s) at lags ``tau`` (n, s) of problems ``rows``;
        with ``slope`` also the profile cost's first and second derivatives in τ (n, s)."""
        n, s = tau.shape
        m = np.arange(5)
        pw = tau[..., None] ** m
        A = np.einsum("nsm,nmkj->nskj", pw, self.A[rows]).reshape(n * s, *self.A.shape[2:])
        b = np.einsum("nsm,nmk->nsk", pw, self.b[rows]).reshape(n * s, -1)
        c = np.einsum("nsm,nm->ns", pw, self.c[rows]).reshape(n * s)
        z, state = box_qp(A, b, self.lo, self.hi)
        cost = 0.5 * (c + 2.0 * np.einsum("nk,nk->n", b, z) + np.einsum("nk,nkj,nj->n", z, A, z))
        if not slope:
            return z.reshape(n, s, -1), cost.reshape(n, s)
        zero = np.zeros_like(pw[..., :1])
        d1 = np.concatenate([zero, m[1:] * pw[..., :-1]], axis=-1)
        d2 = np.concatenate([zero, zero, m[2:] * (m[2:] - 1) * pw[..., :-2]], axis=-1)
        out = []
        for d in (d1, d2):
            Ad = np.einsum("nsm,nmkj->nskj", d, self.A[rows]).reshape(A.shape)
            bd = np.einsum("nsm,nmk->nsk", d, self.b[rows]).reshape(b.shape)
            cd = np.einsum("nsm,nm->ns", d, self.c[rows]).reshape(c.shape)
            out.append((0.5 * (cd + 2.0 * np.einsum("nk,nk->n", bd, z)
                                + np.einsum("nk,nkj,nj->n", z, Ad, z)),
                        bd + np.einsum("nkj,nj->nk", Ad, z)))
        (f1, r), (f2, _) = out
        # the free parameters follow the lag: d²/dτ² of the profile is f_ττ − f_τzᵀ A_FF⁻¹ f_zτ
        free = np.where(state == 0, r, 0.0)
        y = _pattern_solve(A, -free, state, np.zeros_like(self.lo), np.zeros_like(self.lo))
        curv = f2 - np.einsum("nk,nk->n", free, y)
        return z.reshape(n, s, -1), cost.reshape(n, s), f1.reshape(n, s), curv.reshape(n, s)


def _best_lag(prof: _Profile, n: int, lag: str) -> np.ndarray:
    """The lag (n,) of least profile cost: the best of an even grid, then safeguarded Newton
    steps on the profile's slope inside the bracket about it (bisection where Newton leaves it);
    ``lag`` names the lag parameter (its bounds)."""
    t_lo, t_hi = (float(e[0]) for e in bounds([lag]))
    grid = np.linspace(t_lo, t_hi, _LAG_GRID)
    _, cost = prof.at(np.broadcast_to(grid, (n, _LAG_GRID)))
    j = np.argmin(cost, axis=1)
    at_grid, f_grid = grid[j], cost[np.arange(n), j]
    a, c = grid[np.maximum(j - 1, 0)], grid[np.minimum(j + 1, _LAG_GRID - 1)]
    tau = at_grid.copy()
    todo = np.arange(n)
    for _ in range(_LAG_STEPS):
        if not todo.size:
            break
        _, _, d1, d2 = prof.at(tau[todo, None], todo, slope=True)
        d1, d2 = d1[:, 0], d2[:, 0]
        t = tau[todo]
        a[todo] = np.where(d1 < 0, t, a[todo])
        c[todo] = np.where(d1 > 0, t, c[todo])
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = t - d1 / d2
        inside = (d2 > 0) & (newton >= a[todo]) & (newton <= c[todo])
        step = np.where(d1 == 0, t, np.where(inside, newton, 0.5 * (a[todo] + c[todo])))
        tau[todo] = step
        todo = todo[(np.abs(step - t) > _LAG_TOL) & (c[todo] - a[todo] > _LAG_TOL)]
    _, cost = prof.at(tau[:, None])
    return np.where(f_grid < cost[:, 0], at_grid, tau)


def solve_grams(G: np.ndarray, columns: Sequence[str], names: Sequence[str]) -> np.ndarray:
    """The bounded least-squares fits of the residuals whose Gram matrices are ``G`` (n, p, p).

    At a given lag each fit is a box QP (:func:`box_qp`); the lag's profile cost is
    minimised over an even grid of :data:`_LAG_GRID` lags, then Newton steps, the batch in
    lockstep.  Returns (n, len(names)) estimates snapped onto a bound they sit on.
    """
    names = list(names)
    G = np.asarray(G, dtype=float)
    n = len(G)
    j = role_index(names, "lag")
    linear = [k for i, k in enumerate(names) if i != j]
    prof = _Profile(G, columns, linear)
    tau = _best_lag(prof, n, names[j]) if j is not None else np.zeros(n)
    z, _ = prof.at(tau[:, None])
    out = np.empty((n, len(names)))
    out[:, [names.index(k) for k in linear]] = z[:, 0] * prof.size
    if j is not None:
        out[:, j] = tau
    lo, hi = bounds(names)
    return snap_to_bounds(out, lo, hi, scale(names))


def solve_gram(G: np.ndarray, columns: Sequence[str], names: Sequence[str]):
    """The bounded least-squares fit of one Gram matrix ``G`` = ZᵀZ (:func:`solve_grams`):
    ``x`` (snapped estimate) and ``cost`` (half the sum of squared residuals).
    """
    names = list(names)
    x = solve_grams(np.asarray(G)[None], columns, names)[0]
    v, _ = coefficients(columns, names, x)
    return SimpleNamespace(x=x, cost=0.5 * float(v @ G @ v))
