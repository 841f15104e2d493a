"""Inertia-only against augmented balance: fitted on one ride, tested on another.

:func:`cross_ride` accepts the effects that blocked held-out validation on the
fit ride keeps (:func:`select_effects`, the selection rule of every ride fit),
:func:`effect_entries` writes them as CONTRACT's effect entries (the page draws the
held-out prediction: :func:`euc_sim.rides.render.fit_figures.balance_figure`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from euc_sim.rides.balance.design import BOUNDS, NOMINAL, PLAUSIBLE, Design, on_bound, term_role
from euc_sim.rides.balance.fit import BalanceFit, _solve, fit_balance, plausibility
from euc_sim.rides.balance.normal import coefficients, solve_grams
from euc_sim.rides.balance.verdict import unit_label
from euc_sim.stats import forward_select, label_grams, time_blocks

__all__ = ["CrossRide", "cross_ride", "effect_entries", "select_effects", "heldout_score", "admissible", "ADMIT", "HELDOUT_FOLDS", "MIN_GAIN"]

#: Contiguous time folds of the fit ride that score a model held out.
HELDOUT_FOLDS = 5
#: A term is kept only if it lowers the held-out error by more than this fraction.
MIN_GAIN = 0.01


#: What :func:`heldout_score` admits: every model, the models whose terms all lie in
#: their plausible ranges (on an edge allowed), or only those off every bound.
ADMIT = ("any", "plausible", "interior")


def heldout_score(design: Design, names, n_folds: int = HELDOUT_FOLDS, admit: str = "any") -> float:
    """Blocked held-out RMS error of the bounded balance with ``names`` on ``design``, W or N·m.

    Each of ``n_folds`` contiguous time blocks is predicted from a bounded fit
    (:data:`~euc_sim.rides.balance.design.BOUNDS`) on the others.  A model whose
    fit on the whole design is not admitted scores ``inf``: with ``admit`` =
    ``"plausible"``, one with a non-nominal term outside its plausible range;
    with ``"interior"``, also one with a term on a bound (:data:`ADMIT`).
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
    """True when every non-nominal term of ``estimate`` lies in its plausible range.

    A term on an edge of its plausible range (the fit's bound) is admissible: it is
    the most that plausible physics gives, and is accepted at that edge
    (:func:`~euc_sim.rides.balance.design.on_bound` marks it).  ``idle_cap`` (W,
    :attr:`Design.idle_cap`): the ride's own standstill power, above which a
    constant drain P₀ is not plausible.
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

    Forward selection (:func:`euc_sim.stats.forward_select`) from the
    inertia-only model, in two passes of one rule: each step adds the candidate
    that lowers :func:`heldout_score` most, if by more than :data:`MIN_GAIN`,
    first among the models whose terms all lie inside their plausible ranges and
    off their bounds, then, from the model that pass ends with, among those whose
    terms may also sit on an edge of their range.  The interior pass explains
    what plausible physics can without an edge (a single term pushed onto its
    bound would otherwise take the share of two: drag and rolling, or drag and
    P₀); the edge pass adds the loss a ride asks for beyond that, at the most
    plausible physics gives.  A step may add two terms at once (terms each
    inadmissible alone and admissible together; docs/ride_model.md).

    Returns
    -------
    kept : list of str
        In the order kept.
    history : list of dict
        ``{"term", "heldout_rmse"}`` after each step, the inertia-only model first.
    blocked : list of str
        Candidates left that would lower the held-out error of the kept model by
        more than :data:`MIN_GAIN`, but only in a model with a term (theirs or
        another's) outside its plausible range.
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
    """Those of ``names`` whose estimate in ``fit`` lies in its plausible range.

    A term on an edge of its range is admissible at that edge (``on_bound`` in
    :func:`~euc_sim.rides.balance.fit.plausibility`); one outside it (a GPS gain
    below its range, P₀ above the ride's standstill power) stays in the balance, but
    nothing is named or simulated from it.  A term fitted to 0 where 0 means "absent"
    (the lower bound of a loss or a lag) is not admissible either: there is nothing to
    name.  ``idle_cap``: see :func:`_all_admissible`.
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
        Fits on the fit ride: inertia only (nothing fitted); every candidate the ride
        supports; nominal plus the accepted effects alone (:func:`_accepted_model`).
    accepted : tuple of str
        Effects kept by blocked held-out validation on the fit ride
        (:func:`select_effects`) whose estimates are plausible (:func:`admissible`;
        a term may sit on an edge of its plausible range), in the order kept.
    selected : tuple of str
        The terms the selection kept, then those it held out because they lower
        the held-out error only outside their plausible range
        (:func:`select_effects`'s ``blocked``).
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
    """Fit the nominal and augmented balances on one design, measure both on another.

    An effect is *accepted* when blocked held-out validation on the fit ride keeps
    it (:func:`select_effects`) and its bounded estimate is plausible
    (:func:`admissible`).
    ``progress``, when given, is called with a short line before each bootstrapped fit.
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


def effect_entries(cr: CrossRide) -> list[dict]:
    """CONTRACT's effect entries for the accepted effects, strongest first."""
    out = []
    cum = list(NOMINAL)
    phys = plausibility(cr.augmented)
    for c in cr.accepted:
        cum.append(c)
        rmse_after = cr.fit_design_rmse(cum)
        ph = phys[c]
        exact = list(cr.fit_design.aliases.get(c, ()))
        confounded = [x for x in cr.full.confounded(c) if x not in exact]
        aliases = exact + confounded
        step = next((h for h in cr.selection[1:] if c in h["term"].split("+")), None)
        before = cr.selection[max(0, list(cr.selection).index(step) - 1)] if step else None
        ev = (f"adding {ph['symbol']} ({ph['meaning']}) lowers the blocked held-out RMS error "
              f"on {cr.fit_label} from {before['heldout_rmse']:.0f} to {step['heldout_rmse']:.0f} "
              f"{cr.nominal.unit}" if step else f"{ph['symbol']} ({ph['meaning']})")
        ev += f", 95% interval {ph['ci95'][0]:.3g} to {ph['ci95'][1]:.3g} {unit_label(ph['unit'])}"
        if exact:
            ev += (f"; the speed never changes sign, so it is the sum of this and "
                   f"{' and '.join(exact)} (a constant road grade looks the same)")
        if confounded:
            ev += (f"; in the fit with every candidate its estimate trades off against "
                   f"{' and '.join(confounded)} (bootstrap correlation beyond ±0.8): this ride "
                   f"cannot tell them apart")
        if ph["on_bound"]:
            lo, hi = ph["plausible_range"]
            ev += (f"; ON THE EDGE of its plausible range {lo:g} to {hi:g} "
                   f"{unit_label(ph['unit'])}: the ride asks for more than plausible "
                   f"{ph['symbol']} gives, and something the model lacks supplies the rest")
        if not ph["plausible"]:
            ev += (f"; OUTSIDE the plausible range {ph['plausible_range'][0]:g} to "
                   f"{ph['plausible_range'][1]:g} {unit_label(ph['unit'])}: it also absorbs something else")
        entry = {"name": c, "estimate": ph["estimate"], "unit": ph["unit"], "ci95": ph["ci95"],
                 "rmse_after": rmse_after, "aliases": aliases, "evidence": ev,
                 "plausible": ph["plausible"], "plausible_range": ph["plausible_range"],
                 "on_bound": ph["on_bound"]}
        for extra in ("drag_area_m2", "drag_area_m2_ci95", "angle_rad"):
            if extra in ph:
                entry[extra] = ph[extra]
        out.append(entry)
    return out
