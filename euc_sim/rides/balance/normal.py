"""The balance's cost as a quadratic form: fits from the Gram matrices of its basis.

The prediction :meth:`~euc_sim.rides.balance.design.Design.predict_many` is

    P̂ = Σ_j θ_j·(L₂ − τ_I·L₂′ + τ_I²·L₂″)[c_j] + P₀,  θ_inertia = 1,

so the weighted residual w·(P − P̂) is ``Z @ v``: ``Z`` the design's
:attr:`~euc_sim.rides.balance.design.Design.basis` and ``v`` the coefficients, linear in θ for a given
τ_I.  Every fit then needs only ``ZᵀZ`` summed over its rows: a fold leaves out its
blocks' Gram matrices, a wild bootstrap replicate flips the sign of its blocks'
residual cross-products, and the least-squares problem has a few rows instead of the
ride's (scipy's trf takes the same steps: they depend only on JᵀJ and Jᵀr).
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Sequence

import numpy as np

from euc_sim.rides.balance.design import BOUNDS, CANDIDATES, role_index, term_role
from euc_sim.simulation.effects import RECORDS

__all__ = ["coefficients", "solve_gram", "scale", "bounds", "snap_to_bounds"]

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
    p = _SLOTS * len(columns) + 2
    v, dv = np.zeros(p), np.zeros((p, len(names)))
    v[-1] = 1.0
    lag = role_index(names, "lag")
    tau = float(theta[lag]) if lag is not None else 0.0
    filt = np.array([1.0, -tau, tau ** 2])               # L₂ − τ·L₂′ + τ²·L₂″
    scale_of = {"inertia": 1.0}
    for j, n in enumerate(names):
        col = CANDIDATES[n][3]
        if col is not None:
            scale_of[col] = float(theta[j])
            i = columns.index(col)
            dv[_SLOTS * i:_SLOTS * i + _SLOTS, j] = -filt
        elif term_role(n) == "constant":
            v[-2] = -float(theta[j])
            dv[-2, j] = -1.0
    for col, th in scale_of.items():
        i = columns.index(col)
        v[_SLOTS * i:_SLOTS * i + _SLOTS] = -th * filt
        if lag is not None:
            dv[_SLOTS * i + 1, lag] = th
            dv[_SLOTS * i + 2, lag] = -2.0 * tau * th
    return v, dv


def scale(names: Sequence[str]) -> np.ndarray:
    """Typical size of each parameter: ``least_squares``'s ``x_scale`` and the step test."""
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

    scipy's trf keeps iterates strictly inside the box, so a parameter whose optimum
    is a bound comes back a rounding error (1e-30) away from it; on the bound, the
    page can say that it sits there.
    """
    x = np.array(x, dtype=float)
    x = np.where(np.abs(x - lo) <= _BOUND_SNAP * size, lo, x)
    return np.where(np.abs(hi - x) <= _BOUND_SNAP * size, hi, x)


def _root(G: np.ndarray) -> np.ndarray:
    """S with SᵀS = G (G symmetric positive semi-definite): the residual in few rows."""
    lam, U = np.linalg.eigh(0.5 * (G + G.T))
    return np.sqrt(np.clip(lam, 0.0, None))[:, None] * U.T


def solve_gram(G: np.ndarray, columns: Sequence[str], names: Sequence[str], x0: np.ndarray):
    """The bounded least-squares fit of the residual whose Gram matrix is ``G``.

    Without the current lag the model is linear and the cost convex: its unconstrained
    minimum, where it lies inside the bounds, is the answer.  Otherwise scipy's bounded
    ``least_squares`` (trf) from ``x0``.

    Parameters
    ----------
    G : numpy.ndarray
        ZᵀZ over the rows fitted (:attr:`~euc_sim.rides.balance.design.Design.basis`).
    columns : sequence of str
        :attr:`~euc_sim.rides.balance.design.Basis.columns`.
    names : sequence of str
        Parameters to fit.
    x0 : numpy.ndarray
        Start (moved inside the box by a thousandth of its width).

    Returns
    -------
    SimpleNamespace
        ``x`` (bounded estimate, snapped onto a bound it sits on), ``cost`` (half the
        sum of squared residuals at ``x``), ``jac`` (a Jacobian with the rows' JᵀJ).
    """
    from scipy.optimize import least_squares

    names = list(names)
    S = _root(G)
    if not names:
        v, dv = coefficients(columns, names, np.empty(0))
        return SimpleNamespace(x=np.empty(0), cost=0.5 * float(v @ G @ v), jac=np.empty((len(v), 0)))
    lo, hi = bounds(names)
    if role_index(names, "lag") is None:          # linear: the unconstrained optimum, if inside the box
        v0, D = coefficients(columns, names, np.zeros(len(names)))
        A = D.T @ G @ D
        if np.all(np.isfinite(A)) and np.linalg.cond(A) < 1e12:
            x = np.linalg.solve(A, -D.T @ G @ v0)
            if np.all((x > lo) & (x < hi)):
                x = snap_to_bounds(x, lo, hi, scale(names))
                v = v0 + D @ x
                return SimpleNamespace(x=x, cost=0.5 * float(v @ G @ v), jac=S @ D)
    inset = np.where(np.isfinite(hi - lo), 1e-3 * (hi - lo), 1e-9)
    res = least_squares(lambda th: S @ coefficients(columns, names, th)[0],
                        np.clip(x0, lo + inset, hi - inset),
                        jac=lambda th: S @ coefficients(columns, names, th)[1],
                        bounds=(lo, hi), x_scale=scale(names), method="trf")
    x = snap_to_bounds(res.x, lo, hi, scale(names))
    v, dv = coefficients(columns, names, x)
    return SimpleNamespace(x=x, cost=0.5 * float(v @ G @ v), jac=S @ dv)
