"""Inertia-only against augmented balance: fitted on one ride, tested on another.

:func:`cross_ride` accepts the effects blocked held-out validation on the fit ride keeps
(:func:`select_effects`, the selection rule of every ride fit).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from euc_sim.rides.balance.design import BOUNDS, NOMINAL, PLAUSIBLE, Design, on_bound, term_role
from euc_sim.rides.balance.fit import BalanceFit, _solve, fit_balance, plausibility
from euc_sim.rides.balance.normal import coefficients, solve_grams
from euc_sim.stats import forward_select, label_grams, time_blocks

__all__ = ["CrossRide", "cross_ride", "select_effects", "heldout_score", "admissible", "ADMIT", "HELDOUT_FOLDS", "MIN_GAIN"]

#: Contiguous time folds of the fit ride that score a model held out.
HELDOUT_FOLDS = 5
#: A term is kept only if it lowers the held-out error by more than this fraction.
MIN_GAIN = 0.01


#: What :func:`heldout_score` admits: every model, the models whose terms all lie in
#: their plausible ranges (on an edge allowed), or only those off every bound.
ADMIT = ("any", "plausible", "interior")


def heldout_score(design: Design, names, n_folds: int = HELDOUT_FOLDS, admit: str = "any") -> float:
    """Blocked held-out RMS error (W or N·m) of the bounded balance with ``names``: each of
    ``n_folds`` contiguous blocks predicted from the others; ``inf`` when the whole fit is not
    admitted under ``admit`` (:data:`ADMIT`: ``"plausible"``, ``"interior"`` also off the bounds).
    """
    return _HeldoutScores(design, n_folds).score(names, admit)


class _HeldoutScores:
    """:func:`heldout_score` of one design, each model's fits done once.

    The selection's two passes and its ``blocked`` check score the same models
    under different ``admit``: the whole-design fit and the fold error of a model
    (keyed by its names, in order) are kept and reused.
    """

    def __init__(self, design: Design, n_folds: int = HELDOUT_FOLDS):
        self.design, self.n_folds = design, n_folds
        self._whole: dict[tuple, dict] = {}
        self._rmse: dict[tuple, float] = {}
        label = time_blocks(design.t, n_folds)
        self._fold_grams = label_grams(design.basis.Z, label, n_folds)
        self._n = len(label)

    def score(self, names, admit: str = "any") -> float:
        if admit not in ADMIT:
            raise ValueError(f"admit must be one of {ADMIT}, got {admit!r}")
        key = tuple(names)
        if key not in self._whole:
            self._whole[key] = dict(zip(key, _solve(self.design, list(key)).x))
        estimate = self._whole[key]
        if admit != "any" and not _all_admissible(estimate, self.design.idle_cap):
            return float("inf")
        if admit == "interior" and any(on_bound(k, v) for k, v in estimate.items()
                                       if k not in NOMINAL):
            return float("inf")
        if key not in self._rmse:
            self._rmse[key] = self._folds(list(key))
        return self._rmse[key]

    def _folds(self, names: list) -> float:
        """RMS of each fold's residual under the fit on the other folds (from their Grams)."""
        G, cols = self.design.gram, self.design.basis.columns
        sse = 0.0
        fits = solve_grams(G[None] - np.asarray(self._fold_grams), cols, names)
        for Gb, th in zip(self._fold_grams, fits):
            v, _ = coefficients(cols, names, th)
            sse += float(v @ Gb @ v)
        return float(np.sqrt(max(sse, 0.0) / self._n))


def _all_admissible(estimate: dict, idle_cap: float | None = None) -> bool:
    """True when every non-nominal term of ``estimate`` lies in its plausible range (an edge
    included), P₀ not above ``idle_cap`` (W, the ride's standstill power).
    """
    for name, value in estimate.items():
        if name in NOMINAL:
            continue
        rng = PLAUSIBLE.get(name)
        if rng is not None and not rng[0] <= value <= rng[1]:
            return False
        if term_role(name) == "constant" and idle_cap is not None and value > idle_cap:
            return False
    return True


def select_effects(design: Design, candidates) -> tuple[list[str], list[dict], list[str]]:
    """The terms blocked held-out validation keeps, the history, and the terms held out of it.

    Forward selection from the inertia-only model, each step adding the candidate that
    lowers :func:`heldout_score` most by more than :data:`MIN_GAIN`: first among models with
    every term inside its plausible range and off its bounds, then allowing edges.  A step
    may add two terms at once (docs/ride_model.md, "One selection rule, two passes").
    Returns the kept terms in order, ``{"term", "heldout_rmse"}`` after each step, and the
    candidates that help only beside an implausible term (``blocked``).
    """
    others = [c for c in candidates if c not in NOMINAL]
    scores = _HeldoutScores(design)
    names, history = forward_select(lambda n: scores.score(n, "interior"),
                                    list(NOMINAL), others, MIN_GAIN, max_step=2)
    left = [c for c in others if c not in names]
    names, edge = forward_select(lambda n: scores.score(n, "plausible"),
                                 names, left, MIN_GAIN, max_step=2)
    history = history + edge[1:]
    history[0] = {**history[0], "term": history[0]["term"] or "inertia only"}
    cur = history[-1]["heldout_rmse"]
    blocked = [c for c in others if c not in names
               and scores.score(names + [c]) < cur * (1.0 - MIN_GAIN)]
    return names[len(NOMINAL):], history, blocked


def _accepted_model(design: Design, selected) -> list[str]:
    """The kept terms that stay plausible when fitted without the others.

    Terms that leave their plausible range are dropped and the rest refitted, until every
    term left is admissible: the augmented fit (its losses, its held-out error, what is simulated)
    is then the model of the accepted physics alone.
    """
    kept = list(selected)
    while kept:
        ok = admissible(fit_balance(design, list(NOMINAL) + kept, n_boot=0), kept,
                        design.idle_cap)
        if ok == kept:
            break
        kept = ok
    return kept


def admissible(fit: BalanceFit, names, idle_cap: float | None = None) -> list[str]:
    """Those of ``names`` whose estimate in ``fit`` lies in its plausible range (an edge
    included, 0 as "absent" not); ``idle_cap`` as :func:`_all_admissible`.
    """
    phys = plausibility(fit)
    return [c for c in names if phys[c]["plausible"] and not _absent(c, fit.estimate[c])
            and _all_admissible({c: fit.estimate[c]}, idle_cap)]


def _absent(name: str, value: float) -> bool:
    """True when ``value`` sits on a lower bound of 0, which means the term is absent."""
    lo, hi = BOUNDS.get(name, (-np.inf, np.inf))
    return lo == 0.0 and value <= 1e-6 * (hi - lo)


@dataclass(frozen=True)
class CrossRide:
    """Inertia-only against augmented balance, fitted on one ride, tested on another.

    Attributes
    ----------
    nominal, full, augmented : BalanceFit
        Fits on the fit ride: inertia only; every candidate; nominal plus the accepted effects.
    accepted : tuple of str
        Effects kept by :func:`select_effects` whose estimates are :func:`admissible`, in order.
    selected : tuple of str
        The terms the selection kept, then its ``blocked`` ones.
    selection : list of dict
        ``{"term", "heldout_rmse"}`` after each kept step, the inertia-only model first.
    heldout_nominal, heldout_augmented, heldout_full : float
        RMS residual on the test ride, W or N·m.
    """

    fit_design: Design
    test_design: Design
    nominal: BalanceFit
    full: BalanceFit
    augmented: BalanceFit
    accepted: tuple[str, ...]
    heldout_nominal: float
    heldout_augmented: float
    heldout_full: float
    fit_label: str
    test_label: str
    selection: tuple = ()
    selected: tuple = ()

    def fit_design_rmse(self, names) -> float:
        """RMS weighted residual on the fit ride of the bounded fit of ``names`` alone (no
        interval: :func:`fit_balance`'s ``rmse`` without its bootstrap and covariance)."""
        r = self.fit_design.residual(dict(zip(names, map(float, _solve(self.fit_design, list(names)).x))))
        return float(np.sqrt(np.mean(r ** 2)))

    @property
    def ratio(self) -> float:
        """heldout_augmented / heldout_nominal (< 1: the augmented model predicts better)."""
        return self.heldout_augmented / self.heldout_nominal


def cross_ride(fit_design: Design, test_design: Design, n_boot: int = 200, block_s: float = 10.0,
               seed: int = 0, fit_label: str = "fit", test_label: str = "test",
               progress: Callable[[str], None] | None = None) -> CrossRide:
    """Fit the nominal and augmented balances on one design, measure both on another;
    ``progress`` is called with a short line before each bootstrapped fit.
    """
    say = progress or (lambda msg: None)
    common = [c for c in fit_design.candidates if c in test_design.candidates]
    boot = f"{n_boot} bootstrap replicates"
    say(f"fitting the inertia-only balance on {fit_label} (1/3, {boot})")
    nominal = fit_balance(fit_design, list(NOMINAL), n_boot, block_s, seed)
    say(f"fitting every candidate on {fit_label} (2/3, {boot})")
    full = fit_balance(fit_design, common, n_boot, block_s, seed)
    alone, history, blocked = select_effects(fit_design, common)
    kept = _accepted_model(fit_design, alone)
    say(f"fitting the augmented balance ({', '.join(kept) or 'nothing accepted'}) (3/3, {boot})")
    augmented = fit_balance(fit_design, list(NOMINAL) + kept, n_boot, block_s, seed)
    return CrossRide(fit_design=fit_design, test_design=test_design, nominal=nominal, full=full,
                     augmented=augmented, accepted=tuple(kept),
                     selected=tuple(alone) + tuple(blocked),
                     heldout_nominal=nominal.rmse_on(test_design),
                     heldout_augmented=augmented.rmse_on(test_design),
                     heldout_full=full.rmse_on(test_design),
                     fit_label=fit_label, test_label=test_label, selection=tuple(history))
