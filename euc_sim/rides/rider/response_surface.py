"""A quadratic response surface of simulated features in scaled parameters (the rider fit's).

:func:`surface` fits each feature by least squares on design points, :func:`minimise` finds
the parameters whose surface features are nearest (weighted) to a target within a box,
:func:`lhs` draws a Latin hypercube design in a box.  Used by :mod:`euc_sim.rides.rider.rider_fit`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["quad_terms", "surface", "minimise", "lhs"]


def quad_terms(X: np.ndarray) -> np.ndarray:
    """Columns 1, x_i, x_i·x_j (i ≤ j) of the points X (n × d), (n × (1 + d + d(d+1)/2))."""
    X = np.atleast_2d(X)
    cols = [np.ones(len(X))] + [X[:, i] for i in range(X.shape[1])]
    cols += [X[:, i] * X[:, j] for i in range(X.shape[1]) for j in range(i, X.shape[1])]
    return np.stack(cols, axis=1)


def surface(X: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Least-squares quadratic coefficients (1 + d + d(d+1)/2, m) of each feature (columns of
    ``F``, n × m) in the scaled design points ``X`` (n × d).
    """
    coef, *_ = np.linalg.lstsq(quad_terms(X), F, rcond=None)
    return coef


def minimise(coef: np.ndarray, target: np.ndarray, w: np.ndarray, box: np.ndarray,
             starts: np.ndarray) -> np.ndarray:
    """The point of ``box`` (d × 2) whose surface features are nearest to ``target``.

    Minimises Σ w (surface(x) − target)² by L-BFGS-B from each of ``starts`` (k × d) and
    returns the best end point (d,).
    """
    from scipy.optimize import minimize

    def J(x):
        r = quad_terms(x)[0] @ coef - target
        return float(np.sum(w * r * r))

    best = None
    for x0 in starts:
        res = minimize(J, np.clip(x0, box[:, 0], box[:, 1]), method="L-BFGS-B", bounds=box)
        if best is None or res.fun < best.fun:
            best = res
    return best.x


def lhs(n: int, box: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """n points (n × d) of a Latin hypercube in ``box`` (d × 2), drawn with ``rng``."""
    from scipy.stats import qmc

    u = qmc.LatinHypercube(d=len(box), seed=rng).random(n)
    return box[:, 0] + u * (box[:, 1] - box[:, 0])
