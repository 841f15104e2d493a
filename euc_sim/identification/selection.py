"""Generic selection of named candidate terms for a residual, with a nuisance parameter.

This module knows nothing about unicycles.  It is the selection method; the candidate
library (physically derived columns) lives in :mod:`euc_sim.diagnosis.candidates`, in the
spirit of PySINDy's split between a feature library and an optimiser.  The regression
it runs (a residual y(h) with a nuisance h, fits, blocked held-out RMSE, cluster
covariance) is :mod:`euc_sim.identification.regression`.

The residual is *not* white (it has been through a smoothing filter), so the
information criterion (BIC) counts an *effective* number of samples n_eff = n / τ_int,
τ_int the integrated autocorrelation time of the residual.

Forward stepwise selection keeps the history of every step (all trials, their BIC
and held-out RMSE, why the best one was or was not accepted).

Public functions
----------------
:func:`bic`, :func:`forward_select`, :func:`find_aliases`, :func:`generic_gain`,
:func:`sinusoid_basis`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from euc_sim.identification.regression import (Fit, Problem, correlation_time, covariance, fit_set,
                                               heldout_rmse)

__all__ = ["Step", "Selection", "bic", "forward_select", "find_aliases", "generic_gain",
           "sinusoid_basis"]


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
        prefer τ_int of a noise-only residual, as :func:`euc_sim.diagnosis.residual.noise_floor` does).

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
        trials, fits = _trials(problem, current, remaining, n_eff, n_blocks, guard,
                               lambda m: say(f"step {step}: {m}"))
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


def _trials(problem: Problem, current: tuple, remaining: list, n_eff: float, n_blocks: int,
            guard: float, say) -> tuple[list[dict], dict]:
    """Every remaining candidate added to the current set: BIC and held-out RMSE, best BIC first."""
    trials = []
    for c in remaining:
        f = fit_set(problem, current + (c,))
        k = sum(problem.candidates[n].shape[1] + problem.shape_params.get(n, 0) for n in f.names) + 1
        b = bic(f.rss, f.n, n_eff, k)
        cv = heldout_rmse(problem, f.names, n_blocks, guard)
        trials.append({"name": c, "bic": b, "cv_rmse": cv, "rmse": f.rmse, "h": f.h,
                       "theta": f.theta[c].tolist(), "_fit": f})
        say(f"{c}: BIC {b:.1f}, held-out RMSE {cv:.3f}")
    trials.sort(key=lambda d: d["bic"])
    return trials, {d["name"]: d.pop("_fit") for d in trials}


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
    d["cv_gain"] = 1.0 - d["cv_rmse"] / cur_cv if cur_cv > 0 else 0.0     # a zero residual: no gain
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
