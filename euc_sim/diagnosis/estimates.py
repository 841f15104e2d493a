"""Step 4, what the selection names: CONTRACT estimates, intervals, aliases, evidence, limits."""

from __future__ import annotations

import math

import numpy as np

from euc_sim.diagnosis import drift_term
from euc_sim.diagnosis.common import NONLINEAR, THRESHOLDS, plausible_range
from euc_sim.identification import regression as reg
from euc_sim.identification import selection as sel
from euc_sim.simulation import effects

__all__ = ["estimate_of", "coupling_of", "sub_cov", "is_plausible", "alias_estimates", "plausible_alias", "evidence", "effect_items",
           "detection_limits", "drift_of_time"]


def estimate_of(info: dict, theta: np.ndarray, cov: np.ndarray, dof: float) -> tuple[float, list[float], float]:
    """CONTRACT estimate, its 95% interval and standard error from θ and its covariance."""
    from scipy.stats import t as student
    q = float(student.ppf(0.975, max(dof, 1.0)))
    if info.get("drift"):      # peak-to-peak change of the spline Δh(t), delta method
        a, se = drift_term.peak_to_peak(info["drift"], info["span"], np.asarray(theta, float), cov)
        return a, [max(a - q * se, 0.0), a + q * se], se
    if info.get("sqrt"):      # estimate = scale·√θ, interval mapped through the same law
        s, se_s = float(theta[0]), float(np.sqrt(max(cov[0, 0], 0.0)))
        lo, hi = max(s - q * se_s, 0.0), max(s + q * se_s, 0.0)
        est = info["scale"] * math.sqrt(max(s, 0.0))
        se = info["scale"] * se_s / (2.0 * math.sqrt(s)) if s > 0 else float("inf")
        # the scales of the choices the data cannot make (candidates._lateral_info) widen it
        a, b = info.get("scale_range", (info["scale"], info["scale"]))
        return est, [min(a, info["scale"]) * math.sqrt(lo), max(b, info["scale"]) * math.sqrt(hi)], se
    est = info["offset"] + info["scale"] * float(theta[0])
    se = abs(info["scale"]) * float(np.sqrt(max(cov[0, 0], 0.0)))
    return est, [est - q * se, est + q * se], se


def coupling_of(info: dict, theta: np.ndarray, cov: np.ndarray, dof: float) -> dict:
    """The lateral term's coupling ``s`` (1), its Student-t ``s_ci95`` (clipped at 0) and ``alternatives`` (rad
    per √s of each choice)."""
    from scipy.stats import t as student
    q = float(student.ppf(0.975, max(dof, 1.0)))
    s, se_s = float(theta[0]), float(np.sqrt(max(cov[0, 0], 0.0)))
    return {"s": s, "s_ci95": [max(s - q * se_s, 0.0), max(s + q * se_s, 0.0)],
            "alternatives": dict(info.get("alternatives", {"column": info["scale"]}))}


def sub_cov(problem: reg.Problem, names, cov: np.ndarray, name: str) -> np.ndarray:
    i = 0
    for c in names:
        k = problem.candidates[c].shape[1]
        if c == name:
            return cov[i:i + k, i:i + k]
        i += k
    raise KeyError(name)


def is_plausible(name: str, est: float) -> bool:
    """Whether an estimate lies in the catalog's plausible range (|α| for the slope)."""
    e = effects.get(name)
    lo, hi = e.plausible
    if lo < 0:                          # a signed effect: its size
        return abs(est) <= max(abs(lo), abs(hi))
    if e.baseline is not None:          # a parameter's value: its range as it is
        return lo <= est <= hi
    return lo * 0.5 <= est <= hi * 1.5


def alias_estimates(problem: reg.Problem, selected, name: str, aliases, info: dict, dof: float) -> dict:
    """The identified term expressed as each alias's own estimate (e.g. C_rr for rolling resistance, α rad for a slope).

    Swapping the alias's column for ``name`` in ``selected`` (h re-identified) maps the term
    to the alias's unit (docs/diagnosis.md).  Returns ``{alias: {"estimate", "unit", "ci95",
    "t", "rss"}}`` for every alias with a linear single-column term; ``dof`` for the
    Student-t interval.
    """
    without = tuple(c for c in selected if c != name)
    out = {}
    for a in aliases:
        if info[a].get("drift") or a in NONLINEAR or problem.candidates[a].shape[1] != 1:
            continue
        f = reg.fit_set(problem, without + (a,))
        cov, _ = reg.covariance(problem, f)
        est, ci, se = estimate_of(info[a], f.theta[a], sub_cov(problem, without + (a,), cov, a), dof)
        out[a] = {"estimate": est, "unit": effects.get(a).unit, "ci95": ci,
                  "t": abs(est) / se if se > 0 else float("inf"), "rss": f.rss}
    return out


def plausible_alias(swapped: dict):
    """The best-fitting alias (of :func:`alias_estimates`) whose estimate is plausible, or None."""
    ok = [(v["rss"], a) for a, v in swapped.items() if is_plausible(a, v["estimate"])]
    if not ok:
        return None
    a = min(ok)[1]
    v = swapped[a]
    return {"name": a, "estimate": v["estimate"], "unit": v["unit"], "ci95": v["ci95"], "t": v["t"]}


def evidence(name: str, est: float, unit: str, before: float, after: float, t_stat: float,
              aliases: list[str]) -> str:
    u = f" {unit}" if unit and unit != "1" else ""
    txt = (f"adding {name} ({est:.4g}{u}) cuts the held-out residual RMSE from {before:.3g} "
           f"to {after:.3g} N·m; its term stands {t_stat:.0f} standard errors from zero")
    if aliases:
        txt += f", but this recording cannot tell it from {', '.join(aliases)}"
    return txt + "."




def effect_items(prep, problem: reg.Problem, info: dict, s, fin, n_eff: float) -> list[dict]:
    """CONTRACT's ``effects`` list of the selected set: estimate, interval, aliases, evidence."""
    selected = tuple(s.selected)
    out = []
    for i, c in enumerate(selected):
        C = sub_cov(fin.problem, selected, fin.cov, c)
        if c in fin.slopes:   # θ ≈ −(v − v̂)·|dθ/dv|: se_v = se_θ / |dθ/dv|
            C = C / max(fin.slopes[c] ** 2, 1e-12)
            est, ci, se = estimate_of({"offset": fin.info[c]["offset"], "scale": 1.0}, np.zeros(1), C, fin.dof)
        else:
            est, ci, se = estimate_of(fin.info[c], fin.fit.theta[c], C, fin.dof)
        aliases = sel.find_aliases(problem, selected, c, list(problem.candidates), n_eff,
                                   max_bic=THRESHOLDS.alias_bic, cosine=THRESHOLDS.alias_cosine)
        before = s.cv_nominal if i == 0 else s.cv_path[i - 1]
        after = s.cv_path[i] if i < len(selected) - 1 else fin.cv
        ref = effects.RECORDS.absent_value(c, prep.params)     # the value of "no effect"
        t_stat = abs(est - ref) / se if se > 0 else float("inf")
        item = {"name": c, "estimate": est, "unit": effects.get(c).unit, "ci95": ci,
                "rmse_after": after, "aliases": aliases,
                "evidence": evidence(c, est, effects.get(c).unit, before, after, t_stat, aliases)}
        if fin.info[c].get("drift"):
            item.update(drift_of_time(fin.info[c], fin.fit.theta[c], C, fin.fit.h, fin.dof))
        if fin.info[c].get("sqrt"):
            item["coupling"] = coupling_of(fin.info[c], fin.fit.theta[c], C, fin.dof)
        swapped = alias_estimates(problem, selected, c, aliases, info, fin.dof)
        if aliases and not is_plausible(c, est):
            swap = plausible_alias(swapped)
            if swap is not None:
                item = {**swap, "rmse_after": after,
                        "aliases": [c] + [a for a in aliases if a != swap["name"]]}
                item["evidence"] = (evidence(swap["name"], swap["estimate"], swap["unit"], before, after,
                                             swap["t"], item["aliases"])
                                    + f" Named before {c}, whose estimate {est:.3g} is outside its plausible range.")
                item.pop("t", None)
                swapped = {**{k: v for k, v in swapped.items() if k != swap["name"]},
                           c: {"estimate": est, "unit": effects.get(c).unit, "ci95": ci}}
        if swapped:     # the identified quantity in each alias's unit (CONTRACT: an extra field)
            item["alias_estimates"] = {a: {k: v[k] for k in ("estimate", "unit", "ci95")} for a, v in swapped.items()}
        out.append(item)
    return out


def detection_limits(problem: reg.Problem, info: dict, s, vis: dict) -> dict:
    """Per effect, the smallest value this recording would name (``min_t`` × its se, the estimate's unit), against
    the plausible range; invisible ones with the reason."""
    limits = {}
    for c in problem.candidates:
        base_set = tuple(x for x in s.selected if x != c) + (c,)
        f1 = reg.fit_set(problem, base_set)
        cov1, _ = reg.covariance(problem, f1)
        C = sub_cov(problem, base_set, cov1, c)
        se_theta = float(np.sqrt(np.trace(C) / C.shape[0]))
        if info[c].get("drift"):     # the shape this recording shows (its single fit), scaled
            lim = drift_term.unit_shape_limit(info[c]["drift"], info[c]["span"], np.asarray(f1.theta[c], float),
                                              C, THRESHOLDS.min_t)
        elif info[c].get("sqrt"):      # lateral: the coupling grows as tilt², the limit is a tilt
            lim = info[c]["scale"] * math.sqrt(THRESHOLDS.min_t * se_theta)
        else:
            lim = THRESHOLDS.min_t * se_theta * abs(info[c]["scale"])
        lo, hi = plausible_range(c)
        status = ("detectable" if lim <= lo else "only large values" if lim <= hi else "not detectable")
        limits[c] = {"detectable_above": lim, "unit": effects.get(c).unit, "plausible": [lo, hi],
                     "status": status}
    for c, v in vis.items():
        if not v["visible"]:
            limits[c] = {"detectable_above": None, "unit": effects.get(c).unit,
                         "plausible": list(plausible_range(c)), "status": "invisible: " + v["reason"]}
    return limits


def drift_of_time(info: dict, theta, cov: np.ndarray, h: float, dof: float, step: float = 0.25) -> dict:
    """The drift's ``shape``, ``h_of_t`` (``t`` s, ``h`` m, ``ci95_halfwidth`` m every ``step`` s) and ``windows``
    where h changes, s."""
    from scipy.stats import t as student
    t0, t1 = info["span"]
    grid = np.arange(t0, t1 + 1e-9, step)
    theta = np.asarray(theta, float)
    dh, se = drift_term.drift_curve(grid, info["drift"], theta, cov)
    q = float(student.ppf(0.975, max(dof, 1.0)))
    shape = {k: (list(v) if isinstance(v, tuple) else v) for k, v in info["drift"].items()}
    return {"shape": shape,
            "h_of_t": {"t": grid.tolist(), "h": (h + dh).tolist(), "ci95_halfwidth": (q * se).tolist()},
            "windows": drift_term.drift_windows(grid, info["drift"], theta)}
