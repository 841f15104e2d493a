"""Missing physics: locate the mismatch, name what the nominal model left out, model it.

The pipeline reads as the method's steps (docs/diagnosis.md has the derivation):

1. prepare (:mod:`.prepare`): one linear filter applied consistently to q, q̇, q̈
   (and to M_d where recorded), the channels' noise;
2. residual (:mod:`.residual`): r = M_d,1 − M_d,2 (eqs. 9-10) in closed form in h,
   with M_d recorded also the wheel row M_d,1 − M_d; its noise floor;
3. candidates (:mod:`.candidates`): one term per catalog effect, from its physics;
4. select (:mod:`euc_sim.identification.selection`): forward stepwise, blocked
   held-out RMSE, BIC with an effective sample count, jointly with h; the estimates,
   intervals, aliases and detection limits (:mod:`.estimates`);
5. refine (:mod:`.refine`): nonlinear effects by a 1-D search;
6. verdict (:mod:`.verdict`): a generic periodic basis and the noise floor decide
   ``unexplained``; localisation (:mod:`.localise`);
7. model it (:mod:`.resimulate`): the accepted effects injected into the simulator,
   the maneuver re-simulated; report (:mod:`.report`).

Public API: :func:`diagnose`, :func:`json_view`.
"""

from __future__ import annotations

import dataclasses
from typing import Callable, Mapping

import numpy as np

from euc_sim.diagnosis import drift_term
from euc_sim.diagnosis.candidates import build_problem, freeze, visibility
from euc_sim.diagnosis.common import DiagnosisError, COLUMN_H_TOL, COLUMN_ITERATIONS, H_BOUNDS, NONLINEAR, THRESHOLDS
from euc_sim.diagnosis.common import h_at_bound, heldout_over_floor
from euc_sim.diagnosis.estimates import detection_limits, effect_items
from euc_sim.diagnosis.lateral_calibration import (calibrate_item, calibrate_lateral, model_floor, twin_artifacts,
                                                   twin_floor)
from euc_sim.diagnosis.localise import localise, signals_of
from euc_sim.diagnosis.prepare import Prepared, prepare
from euc_sim.diagnosis.refine import Final, final_model, refine, relinearised
from euc_sim.diagnosis.residual import ResidualModel, noise_floor, residual_model
from euc_sim.diagnosis.resimulate import resimulate_recording
from euc_sim.diagnosis.verdict import judge, leftover
from euc_sim.identification import regression as reg
from euc_sim.identification import selection as sel
from euc_sim.model.parameters import Params

__all__ = ["diagnose", "json_view"]

#: Passes of the selection about refined nonlinear values (:func:`refine.relinearised`), and
#: the change of each value below which they stop (s, kg).
RELINEARISE = 2
RELINEARISE_TOL = {"sensor_time_offset": 0.002, "rider_mass": 0.5}


def diagnose(source, *, params: Params | Mapping | None = None, meta: Mapping | None = None,
             resimulate: bool = True, seed: int = 0,
             smoothing=None, progress: Callable[[str], None] | None = None, calibrate: bool = True) -> dict:
    """Diagnose a recording: where the nominal model fails, which catalogued physics is missing, with estimates,
    intervals, aliases and the improvement; decided by :data:`~euc_sim.diagnosis.common.THRESHOLDS`.

    Parameters
    ----------
    source : path or pandas.DataFrame
        A CONTRACT recording (its ``NAME.truth.json`` is never read).
    params : Params or mapping, optional
        Nominal parameters (default the sidecar's, else Table 3); h is always identified.
    meta : mapping, optional
        Metadata when ``source`` is a DataFrame.
    resimulate : bool
        Re-simulate the maneuver with the accepted effects injected.
    seed : int
        Seed of the noise-floor draw.
    smoothing : processing.Smoothing, optional
    progress : callable, optional
        Receives a short message at the start of each step.
    calibrate : bool
        Calibrate a selected ``lateral_dynamics`` on a simulated twin of a 3-D ride
        (:mod:`.lateral_calibration`).

    Returns
    -------
    dict
        CONTRACT's diagnosis object plus ``h_nominal``, ``h_augmented``, ``augmented_rmse``,
        ``noise_floor``, ``decidable``, ``verdict``, ``limits``, ``history`` and more.
    """
    say = progress or (lambda s: None)
    say("1/6 prepare: filtering and differentiating the recording")
    prep = prepare(source, params, meta, smoothing=smoothing)                       # 1 prepare
    vis = visibility(prep.raw.columns)
    model = residual_model(prep)                                                    # 2 residual
    _check_excitation(prep, model)
    time = prep.stacked_time(model.W is not None)
    h0 = reg.fit_set(reg.Problem(model, {}, time, H_BOUNDS), ()).h
    say(f"2/6 residual: nominal h = {h0:.3f} m; the noise floor")
    floor = noise_floor(prep, h0, seed)
    n_eff = max(time.size / floor["tau_int"], 5.0)
    problem, info, s = _select(prep, h0, n_eff, say)                            # 3-4 candidates, select
    say("4/6 refine: estimates and intervals")
    fin = final_model(prep, problem, info, s, say)                                  # 5 refine
    twin = None
    if calibrate and "lateral_dynamics" in s.selected:
        say("4/6 refine: the lateral term calibrated on a simulated twin of the ride")
        twin = calibrate_lateral(prep, fin.fit.h, diagnose)
    floor_test = model_floor(floor["rms_stacked"], twin_floor(twin)) if twin and twin["done"] else floor["rms_stacked"]
    left = leftover(fin, tuple(s.selected), floor_test)                         # 6 verdict
    cv_nominal, periodic = s.cv_nominal, None
    if left["gain"] >= THRESHOLDS.generic_gain:
        # a periodic structure no candidate explains: select again with it fitted beside
        # every set, so that it masks no catalogued effect
        periodic = _periodic_columns(fin, problem.time)
        say("3/6 selection again, beside the periodic structure left")
        problem, info, s = _select(prep, h0, n_eff, say, periodic)
        fin = final_model(prep, problem, info, s, say, periodic)
    eff_out = effect_items(prep, problem, info, s, fin, n_eff)
    if twin and twin["done"]:
        eff_out = [(calibrate_item(e, twin["item"], twin["truth"]) or e) if e["name"] == "lateral_dynamics" else e
                   for e in eff_out]
    limits = detection_limits(problem, info, s, vis)
    _add_blind_windows(limits, model, time, s.fit.h, floor)
    say("5/6 verdict: detection limits, testing what is left")
    decision = judge(eff_out, cv_nominal, fin, limits, vis, left, beside_structure=periodic is not None)
    if twin and twin["done"]:
        twin_artifacts(decision, twin)
    reported = _reported_model(problem, s, fin, decision)
    result = _result(prep, model, problem, s, fin, reported, decision, floor, n_eff, limits, vis, left)
    if twin is not None:
        result["lateral_calibration"] = _twin_summary(twin, floor["rms_stacked"], floor_test)
    if periodic is not None:       # held-out RMSEs of the recording itself, the structure not removed
        result["nominal_rmse"] = cv_nominal
        names = tuple(e["name"] for e in decision["effects"])
        plain, _ = freeze(*build_problem(prep, s.fit.h), names)
        result["augmented_rmse"] = reg.heldout_rmse(plain, names) if names else cv_nominal
        result["periodic_structure"] = {"given": True, "heldout_gain": left["gain"]}
    if resimulate:                                                                  # 7 model it
        say("6/6 model it: re-simulating the maneuver, nominal and augmented")
        rs = resimulate_recording(prep, result)
        result["_series"]["resimulation"] = rs.pop("series", None)
        result["resimulation"] = rs
    # the one "× the noise floor" of the summary and the JSON, of the model reported
    result["heldout_over_floor"] = heldout_over_floor(result["augmented_rmse"], result["noise_floor"])
    return result


def _twin_summary(twin: dict, noise_floor: float, floor_test: float) -> dict:
    """``lateral_calibration`` of the JSON: the twin's plan, truth, estimate, remainder and the test's floor
    (N·m), or why there is none."""
    if not twin["done"]:
        return {"done": False, "reason": twin["reason"], "plan": twin.get("plan")}
    return {"done": True, "plan": twin["plan"], "twin_truth": twin["truth"], "twin_estimate": twin["item"]["estimate"],
            "twin_h": twin["h"], "twin_heldout_rmse": twin["heldout"], "noise_floor": noise_floor,
            "unexplained_floor": floor_test, "rider_noise": twin.get("noisy")}


def _check_excitation(prep: Prepared, model: ResidualModel) -> None:
    """Refuse (DiagnosisError) a recording whose residual is zero at every h: nothing to select on."""
    lo, hi = H_BOUNDS
    rms = max(float(np.sqrt(np.mean(model(h) ** 2))) for h in (lo, 0.5 * (lo + hi), hi))
    if rms < 1e-9:
        ptp = ", ".join(f"{c} {np.ptp(prep.kin.q[:, i]):.2g}" for i, c in enumerate(("x", "γ", "φ")))
        raise DiagnosisError(f"{prep.name}: too little excitation to diagnose anything: the residual "
                             f"M_d,1 − M_d,2 is zero at every h (range over the recording: {ptp}; "
                             "a motionless recording)")


def _nonlinear_hint(problem: reg.Problem, info: dict, s, n_eff: float) -> dict | None:
    """``{name: value}`` of a rider mass or time offset the last step refused though it dropped the BIC by
    ``min_bic_drop`` (its linear column is poor far from nominal); None otherwise."""
    last = s.history[-1]
    if last.accepted or not last.trials:
        return None
    base = sel.bic(s.fit.rss, s.fit.n, n_eff, sel.n_params(problem, s.selected))
    best = None
    for d in last.trials:
        c = d.get("name")
        if c in NONLINEAR and base - d["bic"] >= THRESHOLDS.min_bic_drop and (best is None or d["bic"] < best[0]):
            lo, hi = NONLINEAR[c]
            v = info[c]["offset"] + info[c]["scale"] * float(d["theta"][0])
            if lo <= v <= hi:
                best = (d["bic"], c, v)
    return None if best is None else {best[1]: best[2]}


def _periodic_columns(fin: Final, time: np.ndarray) -> np.ndarray:
    """The 0.1–3 Hz sinusoid (two columns) best fitting what the final model leaves."""
    y = fin.problem.y(fin.fit.h) - fin.problem.design(fin.fit.names) @ fin.fit.coef_vector()
    return sel.sinusoid_basis(time)(np.arange(time.size), y, fin.fit.h)


def _select(prep: Prepared, h0: float, n_eff: float, say, given=None):
    """Candidates and selection, the columns rebuilt at the augmented h (and about refined nonlinear values) until
    it settles."""
    h_cols, state = h0, None
    for it in range(COLUMN_ITERATIONS + RELINEARISE):
        problem, info = build_problem(prep, h_cols) if state is None else relinearised(prep, h_cols, state)
        problem = sel.project_out(problem, given)
        say(f"3/6 candidates and selection: {len(problem.candidates)} candidate terms "
            f"(columns at h = {h_cols:.3f} m)")
        s = sel.forward_select(problem, min_bic_drop=THRESHOLDS.min_bic_drop, min_cv_gain=THRESHOLDS.min_cv_gain,
                               min_t=THRESHOLDS.min_t, n_eff=n_eff, pairs=True)
        nonlin = [c for c in s.selected if c in NONLINEAR]
        hint = _nonlinear_hint(problem, info, s, n_eff) if not nonlin and state is None else None
        if hint and it < COLUMN_ITERATIONS + RELINEARISE - 1:
            # refused only where its linear column is poor: select again about its trial value
            state, h_cols = {"sensor_time_offset": 0.0, "rider_mass": prep.params.m, **hint}, s.fit.h
            continue
        if nonlin and it < COLUMN_ITERATIONS + RELINEARISE - 1:
            # a nonlinear effect far from nominal: select again about its refined value
            est = {c: info[c]["offset"] + info[c]["scale"] * float(s.fit.theta[c][0]) for c in nonlin}
            new = refine(prep, freeze(problem, info, s.selected)[0], s.selected, est, s.fit.h, given)[0]
            moved = state is None or any(abs(new[c] - state[c]) > RELINEARISE_TOL[c] for c in NONLINEAR)
            state, h_cols = new, s.fit.h
            if moved:
                continue
        if not s.selected or abs(s.fit.h - h_cols) < COLUMN_H_TOL:
            break
        h_cols = s.fit.h
    problem, info = freeze(problem, info, s.selected)      # the drift's shape of the selected set
    return problem, info, s


def _add_blind_windows(limits: dict, model: ResidualModel, time: np.ndarray, h: float, floor: dict) -> None:
    """Add ``blind_windows`` (:func:`euc_sim.diagnosis.drift_term.blind_windows`) and ``analysed_span`` (s) to the
    drift's limits."""
    if "cog_height_drift" not in limits:
        return
    drdh = model.slope(h)
    lim = limits["cog_height_drift"]
    lim["analysed_span"] = [float(np.min(time)), float(np.max(time))]
    lim["blind_windows"] = drift_term.blind_windows(time, drdh, floor["rms_stacked"], floor["tau_int"],
                                                    THRESHOLDS.min_t, lim["plausible"][1])


def _reported_model(problem: reg.Problem, s, fin: Final, decision: dict) -> tuple:
    """(problem, fit, held-out RMSE) of the model that is reported: the named effects only."""
    prob_f, fit_f, cv = fin.problem, fin.fit, fin.cv
    tentative = decision["tentative"]
    if tentative:
        named = tuple(e["name"] for e in decision["effects"])
        if any(e["name"] in NONLINEAR for e in tentative):
            prob_f = problem            # the refined residual carried a dropped effect
        if named:
            cv = reg.heldout_rmse(prob_f, named)
            fit_f = reg.fit_set(prob_f, named)
        else:
            cv, fit_f, prob_f = s.cv_nominal, s.nominal, problem
    return prob_f, fit_f, cv


def _localisation(prep: Prepared, model: ResidualModel, h: float) -> tuple[dict, str]:
    """Localise on the row that carries the mismatch (the wheel row where it dominates)."""
    r_loc, loc_row = model.kinematic(h), "M_d,1 - M_d,2"
    if model.W is not None:
        r_w = model.wheel(h)
        if np.sqrt(np.mean(r_w ** 2)) > np.sqrt(np.mean(r_loc ** 2)):
            r_loc, loc_row = r_w, "M_d,1 - M_d (wheel row)"
    return localise(prep.kin.t[prep.keep], r_loc, signals_of(prep)), loc_row


def _result(prep, model, problem, s, fin, reported, decision, floor, n_eff, limits, vis, left) -> dict:
    """CONTRACT's diagnosis object, with the private ``_series`` for the report's figures."""
    has_w = model.W is not None
    prob_f, fit_f, cv_after_all = reported
    cov_nom, _ = reg.covariance(problem, s.nominal)
    h_se = float(np.sqrt(cov_nom[-1, -1]))
    h_se_f = float(np.sqrt(max(fin.cov[-1, -1], 0.0)))
    loc, loc_row = _localisation(prep, model, s.nominal.h)
    named = decision["effects"]
    if named and named[0].get("windows") is not None:    # a drift: where h changes
        loc = {**loc, "windows": named[0]["windows"]}
        loc_row = "h(t) of cog_height_drift, where it changes"
    result = {
        "recording": prep.name,
        "nominal_rmse": s.cv_nominal,
        "effects": decision["effects"],
        "unexplained": decision["unexplained"],
        "tentative": decision["tentative"],
        "windows": loc["windows"],
        "augmented_rmse": cv_after_all,
        "h_nominal": s.nominal.h,
        "h_nominal_ci95": [s.nominal.h - 1.96 * h_se, s.nominal.h + 1.96 * h_se],
        "h_augmented_ci95": [fit_f.h - 1.96 * h_se_f, fit_f.h + 1.96 * h_se_f],
        "h_augmented": fit_f.h,
        "nominal_params": {k: v for k, v in dataclasses.asdict(prep.params).items() if k != "h"},
        "residual": "M_d,1 - M_d,2" + (" and wheel row M_d,1 - M_d" if has_w else ""),
        "rmse_unit": "N·m",
        "noise_floor": floor["rms_stacked"],
        "noise_sd": prep.noise_sd,
        "n_eff": n_eff,
        "decidable": decision["decidable"],
        "verdict": decision["verdict"],
        "notes": list(decision["notes"]),
        "cannot_see": decision["cannot_see"],
        "limits": limits,
        "visibility": vis,
        "correlations": loc["correlations"],
        "window_share": loc["share"],
        "localised_on": loc_row,
        "generic": {k: left[k] for k in ("heldout_without", "heldout_with", "gain", "floor_ratio")},
        "history": [{"step": st.step, "base": list(st.base), "chosen": st.chosen,
                     "accepted": st.accepted, "reason": st.reason, "trials": st.trials}
                    for st in s.history],
        "thresholds": THRESHOLDS.__dict__,
    }
    hits = _at_bound(s.nominal.h, fit_f.h, fin, decision)
    result["at_bound"] = [key for key, _ in hits]
    result["notes"] += [sentence for _, sentence in hits if sentence]
    nk = prep.keep.size
    y_fin = prob_f.y(fit_f.h) - prob_f.design(fit_f.names) @ fit_f.coef_vector()
    result["_series"] = {
        "t": prep.kin.t[prep.keep],
        "residual_nominal": model.kinematic(s.nominal.h),
        "residual_augmented": y_fin[:nk],
        "wheel_nominal": model.wheel(s.nominal.h),
        "wheel_augmented": y_fin[nk:] if has_w else None,
        "terms": {c: problem.candidates[c][:nk] for c in problem.candidates},
        "single_fits": _single_fits(problem, nk),
        "signals": signals_of(prep),
    }
    return result


def _at_bound(h_nominal: float, h_augmented: float, fin: Final, decision: dict) -> list[tuple[str, str]]:
    """Every fitted quantity that ends on its search bound: (JSON key, a note, "" where the verdict's note already
    says it)."""
    lo, hi = H_BOUNDS
    hits = []
    if h_at_bound(h_nominal):
        hits.append(("h_nominal", f"the nominal h = {h_nominal:.3f} m lies on the search bound "
                                  f"[{lo:g}, {hi:g}] m: it is a bound, not a minimum"))
    if h_at_bound(h_augmented):
        said = h_at_bound(fin.fit.h)             # the verdict's note names it
        hits.append(("h_augmented", "" if said else
                     f"h = {h_augmented:.3f} m with the named effects lies on the search bound "
                     f"[{lo:g}, {hi:g}] m: it is a bound, not a minimum"))
    for where in ("effects", "tentative"):
        for e in decision[where]:
            info = fin.info.get(e["name"], {})
            if info.get("at_bound"):
                a, b = info["search"]
                hits.append((f"{where}.{e['name']}",
                             f"{e['name']} = {e['estimate']:.4g} {e['unit']} lies on its search bound "
                             f"[{a:.4g}, {b:.4g}] {e['unit']}: it is a bound, not an estimate"))
    return hits


def _single_fits(problem: reg.Problem, nk: int) -> dict:
    """Each candidate alone with h: (residual at its h, its term, h, and the same two for the wheel row or None)."""
    out = {}
    for c in problem.candidates:
        f = reg.fit_set(problem, (c,))
        y, term = problem.y(f.h), problem.candidates[c] @ f.theta[c]
        out[c] = (y[:nk], term[:nk], f.h, y[nk:] if y.size > nk else None,
                  term[nk:] if y.size > nk else None)
    return out


def json_view(result: dict) -> dict:
    """The result without its private arrays (keys starting with ``_``), for JSON."""
    return {k: v for k, v in result.items() if not k.startswith("_")}
