"""Forward stepwise selection of named candidate terms for a residual y(h) with a nuisance h.

Generic (no unicycle here): the candidate library is :mod:`euc_sim.diagnosis.candidates`,
the regression (fits, blocked held-out RMSE, cluster covariance)
:mod:`euc_sim.identification.regression`.  The residual is filtered, so the BIC counts
n_eff = n / τ_int samples, τ_int the integrated autocorrelation time.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from euc_sim.identification.regression import (Adapted, Fit, Problem, correlation_time, covariance,
                                               fit_set, heldout_rmse)

__all__ = ["Step", "Selection", "bic", "forward_select", "find_aliases", "generic_gain",
           "sinusoid_basis", "project_out", "n_params", "group_t", "invalid_terms"]


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
        Accepted candidates in the order of acceptance.
    fit, nominal : Fit
        Final fit on all samples; fit of the nuisance alone.
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


#: Most candidates a selection accepts.
MAX_TERMS = 3


def forward_select(problem: Problem, *, min_bic_drop: float = 10.0, min_cv_gain: float = 0.10,
                   min_t: float = 4.0, n_eff: float | None = None, pairs: bool = False) -> Selection:
    """Forward stepwise selection with blocked held-out validation and BIC.

    Each step adds every remaining candidate in turn (h re-identified); the lowest-BIC one
    is accepted when the BIC drops by ``min_bic_drop``, the held-out RMSE
    (:func:`~euc_sim.identification.regression.heldout_rmse`) by the fraction
    ``min_cv_gain``, each coefficient group has |θ|/se ≥ ``min_t`` (cluster sandwich of
    :data:`~euc_sim.identification.regression.CLUSTER` s) and ``problem.validity`` has no
    objection; at most :data:`MAX_TERMS` are accepted.  Otherwise selection stops.

    Parameters
    ----------
    problem : Problem
    min_bic_drop, min_cv_gain, min_t : float
        Acceptance thresholds.
    n_eff : float, optional
        Effective sample count for the BIC (default n / τ_int of the nominal residual).
    pairs : bool
        When no single candidate earns its place try pairs (each must earn its place given
        the other), and after each acceptance try a swap and a backward step.

    Returns
    -------
    Selection
    """
    pool = list(problem.candidates)
    nominal = fit_set(problem, ())
    y0 = problem.y(nominal.h)
    tau = correlation_time(y0)
    n_eff = max(problem.n / tau, 5.0) if n_eff is None else float(n_eff)
    cv_nom = heldout_rmse(problem, ())
    current, cur_fit, cur_cv = (), nominal, cv_nom
    cur_bic = bic(nominal.rss, nominal.n, n_eff, 1)
    history: list[Step] = [Step(0, (), [{"name": None, "bic": cur_bic, "cv_rmse": cv_nom,
                                         "rmse": nominal.rmse, "h": nominal.h}], None, True,
                                "nominal model: h only")]
    judge = dict(min_bic_drop=min_bic_drop, min_cv_gain=min_cv_gain, min_t=min_t)
    dropped: tuple = ()
    for step in range(1, 2 * MAX_TERMS + 2):
        remaining = [c for c in pool if c not in current and c not in dropped]
        if not remaining or len(current) >= MAX_TERMS:
            break
        trials, fits = _trials(problem, current, remaining, n_eff)
        accepted, chosen, reason, f, best = False, None, "no candidate left", None, None
        refused = []
        for d in trials:
            f = fits[d["name"]]
            reasons = _judge(problem, f, d, cur_bic, cur_cv, **judge)
            if not reasons:
                accepted, chosen, best = True, d["name"], d
                break
            refused.append(f"{d['name']}: " + "; ".join(reasons))
            if d["bic"] > cur_bic - min_bic_drop or d.get("cv_gain", 0.0) < min_cv_gain:
                chosen, best = d["name"], d          # the best plausible one is not good enough
                break                                # (else refused on physics: try the next)
        reason = "accepted" + (f" (refused before it: {' | '.join(refused)})" if refused else "") \
            if accepted else " | ".join(refused) or reason
        if not accepted and pairs and len(current) + 2 <= MAX_TERMS:
            # no single term earns its place: two that only show together (each masks the other)
            pair = _pair_step(problem, current, remaining, n_eff, cur_bic, cur_cv, judge)
            if pair is not None:
                accepted, chosen, f, best = True, "+".join(pair["names"]), pair["_fit"], pair
                reason = f"accepted as a pair (alone: {' | '.join(refused)})"
                trials = trials + [{k: v for k, v in pair.items() if k != "_fit"}]
        history.append(Step(step, current, trials, chosen, accepted, reason))
        if not accepted:
            break
        current, cur_fit, cur_cv, cur_bic = f.names, f, best["cv_rmse"], best["bic"]
        if not pairs:
            pool = [c for c in pool if c not in {r.split(":", 1)[0] for r in refused}]   # refused on physics
            continue
        # swap: a member that another candidate replaces decisively, given the rest (an alias
        # chosen before the set's other members were known)
        swap = _swap(problem, cur_fit, cur_bic, [c for c in pool if c not in current], n_eff, min_bic_drop, min_t)
        if swap is not None:
            old_name, g, b_new = swap
            history.append(Step(step, current, [], g.names[-1], True,
                                f"swapped {old_name} for {g.names[-1]}: BIC {cur_bic:.1f} -> {b_new:.1f}"))
            current, cur_fit, cur_bic = g.names, g, b_new
            cur_cv = heldout_rmse(problem, current)
        # backward: a term that the later ones made redundant leaves the set
        gone, why = _backward(problem, cur_fit, cur_bic, n_eff, min_bic_drop, min_t)
        dropped = (gone,) if gone else ()
        if gone:
            current = tuple(c for c in current if c != gone)
            cur_fit = fit_set(problem, current)
            cur_bic = bic(cur_fit.rss, cur_fit.n, n_eff, n_params(problem, current))
            cur_cv = heldout_rmse(problem, current)
            history.append(Step(step, f.names, [], gone, False, f"dropped {gone}: {why}"))
    cv_path = [heldout_rmse(problem, current[:i + 1]) for i in range(len(current) - 1)] + \
        ([cur_cv] if current else [])
    return Selection(current, cur_fit, nominal, cv_nom, cur_cv, cv_path, n_eff, tau, history)


def _trials(problem: Problem, current: tuple, remaining: list, n_eff: float) -> tuple[list[dict], dict]:
    """Every remaining candidate added to the current set: BIC and held-out RMSE, best BIC first."""
    trials = []
    for c in remaining:
        f = fit_set(problem, current + (c,))
        b = bic(f.rss, f.n, n_eff, n_params(problem, f.names))
        cv = heldout_rmse(problem, f.names)
        trials.append({"name": c, "bic": b, "cv_rmse": cv, "rmse": f.rmse, "h": f.h,
                       "theta": f.theta[c].tolist(), "_fit": f})
    trials.sort(key=lambda d: d["bic"])
    return trials, {d["name"]: d.pop("_fit") for d in trials}


def _pair_step(problem: Problem, current: tuple, remaining: list, n_eff: float, cur_bic: float, cur_cv: float,
               judge: dict) -> dict | None:
    """The best pair of remaining candidates added together when it passes :func:`forward_select`'s tests and each
    member drops the BIC by ``min_bic_drop`` given the other."""
    tried = []
    for i, a in enumerate(remaining):
        for b in remaining[i + 1:]:
            f = fit_set(problem, current + (a, b))
            tried.append((bic(f.rss, f.n, n_eff, n_params(problem, f.names)), a, b, f))
    tried.sort(key=lambda x: x[0])
    for b_ab, a, b, f in tried:
        if cur_bic - b_ab < judge["min_bic_drop"]:
            return None
        if invalid_terms(problem, f):
            continue
        cov, _ = covariance(problem, f)
        t = {c: group_t(problem, f, cov, c) for c in (a, b)}
        if min(t.values()) < judge["min_t"]:
            continue
        alone = {}
        for c, other in ((a, b), (b, a)):
            g = fit_set(problem, current + (other,))
            alone[c] = bic(g.rss, g.n, n_eff, n_params(problem, g.names)) - b_ab
        if min(alone.values()) < judge["min_bic_drop"]:
            continue
        cv = heldout_rmse(problem, f.names)
        gain = 1.0 - cv / cur_cv if cur_cv > 0 else 0.0
        if gain < judge["min_cv_gain"]:
            continue
        return {"name": f"{a}+{b}", "names": (a, b), "bic": b_ab, "cv_rmse": cv, "rmse": f.rmse, "h": f.h,
                "theta": np.concatenate([f.theta[a], f.theta[b]]).tolist(), "t": min(t.values()),
                "cv_gain": gain, "_fit": f}
    return None


def _swap(problem: Problem, f: Fit, cur_bic: float, others: list, n_eff: float, min_bic_drop: float,
          min_t: float):
    """The best replacement of one member by an outsider lowering the BIC by ``min_bic_drop`` (valid, newcomer
    |θ|/se ≥ ``min_t``): (replaced name, fit, BIC), or None."""
    if len(f.names) < 2:
        return None
    best = None
    for c in f.names:
        rest = tuple(n for n in f.names if n != c)
        for a in others:
            g = fit_set(problem, rest + (a,))
            b = bic(g.rss, g.n, n_eff, n_params(problem, g.names))
            if cur_bic - b >= min_bic_drop and (best is None or b < best[2]) and not invalid_terms(problem, g):
                cov, _ = covariance(problem, g)
                if group_t(problem, g, cov, a) >= min_t:
                    best = (c, g, b)
    return best


def _backward(problem: Problem, f: Fit, cur_bic: float, n_eff: float, min_bic_drop: float,
              min_t: float) -> tuple[str | None, str]:
    """The member whose removal costs the least BIC, when below ``min_bic_drop`` or its |θ|/se below ``min_t``,
    and why; (None, "") otherwise."""
    if len(f.names) < 2:
        return None, ""
    cov, _ = covariance(problem, f)
    worst, why, worst_cost = None, "", np.inf
    for c in f.names:
        rest = tuple(n for n in f.names if n != c)
        g = fit_set(problem, rest)
        cost = bic(g.rss, g.n, n_eff, n_params(problem, rest)) - cur_bic
        t = group_t(problem, f, cov, c)
        if (cost < min_bic_drop or t < min_t) and cost < worst_cost:
            worst, worst_cost = c, cost
            why = f"given {', '.join(rest)} it lowers the BIC by {cost:.1f} (|θ|/se {t:.1f})"
    return worst, why


def n_params(problem: Problem, names: Sequence[str]) -> int:
    """Parameters of a set counted by the BIC: its columns, the shapes' chosen parameters, h."""
    ad = [problem.adapted(c, names) for c in names]
    return sum(a.columns.shape[1] + a.n_shape for a in ad) + 1


def group_t(problem: Problem, f: Fit, cov: np.ndarray, name: str) -> float:
    """|θ|/se of candidate ``name`` in ``f``; for a group of k columns √max(W − (k − 1), 0), W its Wald statistic."""
    i0 = 0
    for c in f.names:
        k = f.theta[c].size
        if c == name:
            break
        i0 += k
    tg, Cg = f.theta[name], cov[i0:i0 + k, i0:i0 + k]
    if k == 1:
        return float(abs(tg[0]) / np.sqrt(max(Cg[0, 0], 1e-300)))
    try:
        wald = float(tg @ np.linalg.solve(Cg, tg))
    except np.linalg.LinAlgError:
        wald = 0.0
    return float(np.sqrt(max(wald - (k - 1), 0.0)))


def invalid_terms(problem: Problem, f: Fit) -> list[str]:
    """Every member of the fitted set whose estimate is not physics, with why."""
    out = []
    for c in f.names:
        check = problem.adapted(c, f.names).check
        why = check(f.theta[c]) if check else None
        if why:
            out.append(f"{c}: {why}")
    return out


def _judge(problem: Problem, f: Fit, d: dict, cur_bic: float, cur_cv: float,
           min_bic_drop: float, min_cv_gain: float, min_t: float) -> list[str]:
    """Reasons to refuse the trial ``d`` (fit ``f``); empty when it is accepted."""
    name = d["name"]
    cov, _ = covariance(problem, f)
    t_new = group_t(problem, f, cov, name)
    d["t"] = t_new
    d["cv_gain"] = 1.0 - d["cv_rmse"] / cur_cv if cur_cv > 0 else 0.0     # a zero residual: no gain
    reasons = []
    if cur_bic - d["bic"] < min_bic_drop:
        reasons.append(f"BIC drop {cur_bic - d['bic']:.1f} < {min_bic_drop:g}")
    if d["cv_gain"] < min_cv_gain:
        reasons.append(f"held-out RMSE gain {100 * d['cv_gain']:.1f}% < {100 * min_cv_gain:.0f}%")
    if t_new < min_t:
        reasons.append(f"|θ|/se {t_new:.1f} < {min_t:g}")
    for why in invalid_terms(problem, f):      # every member: a new term may turn an old one unphysical
        reasons.append(why.split(": ", 1)[1] if why.startswith(name + ":") else why)
    return reasons


def find_aliases(problem: Problem, selected: Sequence[str], name: str,
                 candidates: Sequence[str], n_eff: float, max_bic: float = 10.0,
                 cosine: float = 0.95) -> list[str]:
    """Candidates this recording cannot tell apart from ``name``.

    ``a`` is an alias when, with ``name`` swapped for ``a`` in ``selected`` (h re-identified),
    the fit is valid and its BIC within ``max_bic`` of the accepted set's, or when the two
    single columns have |cosine| ≥ ``cosine``.
    """
    selected = tuple(selected)
    without = tuple(c for c in selected if c != name)
    f_with = fit_set(problem, selected)
    out = []
    for a in candidates:
        if a == name or a in selected:
            continue
        Xa, Xn = problem.columns(a, without + (a,)), problem.columns(name, selected)
        cos = 0.0
        if Xa.shape[1] == 1 and Xn.shape[1] == 1:
            na, nn = np.linalg.norm(Xa), np.linalg.norm(Xn)
            cos = float(abs(Xa[:, 0] @ Xn[:, 0]) / (na * nn)) if na > 0 and nn > 0 else 0.0
        f_a = fit_set(problem, without + (a,))
        valid = not invalid_terms(problem, f_a)
        k_extra = n_params(problem, f_a.names) - n_params(problem, selected)
        d_bic = n_eff * np.log(max(f_a.rss, 1e-300) / max(f_with.rss, 1e-300)) + k_extra * np.log(n_eff)
        if valid and (cos >= cosine or d_bic < max_bic):
            out.append(a)
    return out


def project_out(problem: Problem, P: np.ndarray | None) -> Problem:
    """The problem with the columns ``P`` (n, k) projected out of the target and every candidate (``None``:
    ``problem``)."""
    if P is None:
        return problem
    P = np.asarray(P, dtype=float).reshape(problem.n, -1)
    Q, _ = np.linalg.qr(P)

    def proj(X):
        X = np.asarray(X, dtype=float)
        return X - Q @ (Q.T @ X)

    def target(h):
        return proj(problem.y(h))

    def wrap(hook):
        def adapted(others):
            a = hook(others)
            return Adapted(proj(np.asarray(a.columns, float)), a.n_shape, a.check)
        if hasattr(hook, "shape"):
            adapted.shape = hook.shape
        return adapted

    return Problem(target, {c: proj(X) for c, X in problem.candidates.items()}, problem.time, problem.bounds,
                   problem.validity, problem.shape_params,
                   {c: wrap(hk) for c, hk in problem.adaptive.items()})


def sinusoid_basis(time: np.ndarray, fmin: float = 0.1, fmax: float = 3.0, n_freq: int = 300):
    """An ``extra`` for :func:`heldout_rmse`: the sinusoid in [fmin, fmax] Hz best fitting the training residual,
    as two full-length columns."""
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


def generic_gain(problem: Problem, selected: Sequence[str], extra: Callable) -> tuple[float, float]:
    """Held-out RMSE ``(without, with)`` a generic basis ``extra`` on top of ``selected``."""
    return heldout_rmse(problem, selected), heldout_rmse(problem, selected, extra=extra)
