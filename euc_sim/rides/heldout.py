"""Terms kept by held-out validation, one step at a time, for the ride fits (mass, PWM).

The diagnosis's :func:`euc_sim.identification.selection.forward_select` judges a
step by BIC, held-out RMSE and |θ|/se on a :class:`Problem`; a ride's energy
balance and duty model are plain least squares on a few speed-only columns, so
the held-out score alone decides, through :func:`select_by_heldout`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["select_by_heldout", "time_blocks"]


def time_blocks(t: np.ndarray, n_blocks: int) -> np.ndarray:
    """Fold label 0 … n_blocks − 1 of each sample: contiguous time blocks of equal counts.

    Parameters
    ----------
    t : ndarray
        Sample times, s, increasing.
    n_blocks : int
        Number of blocks.

    Returns
    -------
    ndarray of int
    """
    edges = np.quantile(t, np.linspace(0, 1, n_blocks + 1))
    return np.clip(np.searchsorted(edges, t, side="right") - 1, 0, n_blocks - 1)


def select_by_heldout(score, base: list, candidates: list, min_gain: float) -> tuple[list, list]:
    """Forward selection by a held-out score: add the candidate that lowers it most.

    Parameters
    ----------
    score : callable
        ``score(names) -> float``, the held-out RMSE of the model with those terms.
    base : list of str
        Terms always in the model.
    candidates : list of str
        Terms tried, one more per step.
    min_gain : float
        A step is kept only if it lowers the score by more than this fraction.

    Returns
    -------
    names : list of str
        ``base`` plus the kept terms, in the order kept.
    history : list of dict
        ``{"term", "heldout_rmse"}`` after each step, the base model (terms joined by "+") first.
    """
    names = list(base)
    cur = score(names)
    history = [{"term": "+".join(base), "heldout_rmse": cur}]
    left = list(candidates)
    while left:
        trial = {c: score(names + [c]) for c in left}
        best = min(trial, key=trial.get)
        if trial[best] > cur * (1.0 - min_gain):
            break
        names.append(best)
        left.remove(best)
        cur = trial[best]
        history.append({"term": best, "heldout_rmse": cur})
    return names, history
