"""Step 5, refine: nonlinear effects (time offset, rider mass) by a 1-D search each."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from euc_sim.diagnosis.candidates import build_problem, freeze, validity_rules
from euc_sim.diagnosis.common import NONLINEAR, SEARCH
from euc_sim.diagnosis.prepare import Prepared
from euc_sim.diagnosis.residual import residual_model
from euc_sim.identification import regression as reg
from euc_sim.identification import selection as sel
from euc_sim.simulation import effects

__all__ = ["refine", "relinearised", "Final", "final_model"]


def refine(prep: Prepared, problem: reg.Problem, selected, estimates: dict, h: float, given):
    """Estimate nonlinear effects (time offset, rider mass) by a 1-D search each over the value itself, h and the
    linear effects profiled out.

    Returns the state ``{name: value}``, the rebuilt (problem, info) (each refined effect's
    info with its ``search`` interval and ``at_bound``), the fit, and the slope dθ/dv of each
    linearised coefficient.  ``given``: columns fitted beside every set, or None.
    """
    p = prep.params
    nonlin = [c for c in selected if c in NONLINEAR]
    linear = tuple(c for c in selected if c not in NONLINEAR)
    state = {"sensor_time_offset": 0.0, "rider_mass": p.m}
    state.update({c: estimates[c] for c in nonlin})
    lin_cols = {c: problem.candidates[c] for c in linear}

    def residual_of(st):
        pr = prep.shifted(st["sensor_time_offset"]) if st["sensor_time_offset"] else prep
        pp = effects.apply_to_params(p, "rider_mass", st["rider_mass"]) if st["rider_mass"] != p.m else p
        return pr, pp

    def rss(c, v):
        st = {**state, c: v}
        pr, pp = residual_of(st)
        prob = reg.Problem(residual_model(pr, pp), {}, problem.time, problem.bounds)
        prob = sel.project_out(prob, given)
        prob = reg.Problem(prob.target, lin_cols, prob.time, prob.bounds)
        return reg.fit_set(prob, linear).rss

    searched = {}
    for _ in range(2 if len(nonlin) > 1 else 1):
        for c in nonlin:
            lo, hi = NONLINEAR[c]
            v0 = state[c]
            w, xatol, _ = SEARCH[c]
            a, b = max(lo, v0 - w), min(hi, v0 + w)
            res = minimize_scalar(lambda v: rss(c, v), bounds=(a, b), method="bounded",
                                  options={"xatol": xatol})
            state[c] = float(res.x)
            searched[c] = ((a, b), min(state[c] - a, b - state[c]) <= 3 * xatol)

    def build(st):
        pr, pp = residual_of(st)
        prob, inf = build_problem(pr, h, pp)
        return freeze(sel.project_out(prob, given), inf, selected)

    prob, info = build(state)
    f = reg.fit_set(prob, selected)
    slopes = {}
    for c in nonlin:
        d = SEARCH[c][2]
        pa, _ = build({**state, c: state[c] - d})
        pb, _ = build({**state, c: state[c] + d})
        ta = reg.fit_set(pa, selected).theta[c][0]
        tb = reg.fit_set(pb, selected).theta[c][0]
        slopes[c] = float((tb - ta) / (2 * d))
        info[c] = {**info[c], "offset": state[c], "scale": 0.0, "search": searched[c][0],
                   "at_bound": bool(searched[c][1])}
    return state, prob, info, f, slopes




def relinearised(prep: Prepared, h: float, state: dict) -> tuple[reg.Problem, dict]:
    """The selection problem linearised about refined values ``state`` instead of the nominal ones.

    Target r_v(h) + Σ X_v·(v − v_0): equal to the nominal residual to first order about v, so
    θ is again v − v_0 and fits exactly where v is right.
    """
    p = prep.params
    nominal = {"sensor_time_offset": 0.0, "rider_mass": p.m}
    delta = {c: state[c] - nominal[c] for c in nominal if abs(state[c] - nominal[c]) > 0}
    pr = prep.shifted(state["sensor_time_offset"]) if state["sensor_time_offset"] else prep
    pp = effects.apply_to_params(p, "rider_mass", state["rider_mass"]) if state["rider_mass"] != p.m else p
    prob, info = build_problem(pr, h, pp)
    shift = sum(prob.candidates[c][:, 0] * d for c, d in delta.items() if c in prob.candidates)

    def target(hh):
        return prob.y(hh) + shift

    info = {**info, **{c: {**info[c], "offset": nominal[c]} for c in nominal if c in info}}
    rules = validity_rules(p, (float(prep.kin.t[0]), float(prep.kin.t[-1])), None)    # θ is v − v_0 again
    validity = {**prob.validity, **{c: rules[c] for c in nominal if c in prob.validity}}
    return reg.Problem(target, prob.candidates, prob.time, prob.bounds, validity, prob.shape_params,
                       prob.adaptive), info


@dataclass(frozen=True)
class Final:
    """The model after selection and refinement, whose estimates are reported.

    Attributes
    ----------
    problem : regression.Problem
    info : dict
        Estimate maps (``build_problem``).
    fit : regression.Fit
    slopes : dict
        dθ/dv of each refined nonlinear effect.
    cov : numpy.ndarray
        Covariance of (θ, h), 2 s clusters.
    dof : float
    cv : float
        Held-out RMSE of the selected set, N·m.
    """

    problem: reg.Problem
    info: dict
    fit: reg.Fit
    slopes: dict
    cov: np.ndarray
    dof: float
    cv: float


def final_model(prep: Prepared, problem: reg.Problem, info: dict, s, progress, given=None) -> Final:
    """The selection ``s``'s model, its nonlinear effects refined (``progress`` told); ``given``: columns fitted
    beside every set, or None."""
    selected = tuple(s.selected)
    estimates = {c: info[c]["offset"] + info[c]["scale"] * float(s.fit.theta[c][0])
                 for c in selected if not info[c].get("drift")}
    prob_f, info_f, fit_f, slopes = problem, info, s.fit, {}
    if any(c in selected for c in NONLINEAR):
        progress("4/6 refine: 1-D search of the nonlinear estimates")
        _, prob_f, info_f, fit_f, slopes = refine(prep, problem, selected, estimates, s.fit.h, given)
    cov_f, dof_f = reg.covariance(prob_f, fit_f)
    cv = reg.heldout_rmse(prob_f, selected) if selected else s.cv_nominal
    return Final(prob_f, info_f, fit_f, slopes, cov_f, dof_f, cv)
