"""Scoring of the blind study (``blind_study.py`` here): what was named against the truth.

:func:`score` tallies the confusion table, the estimate errors and the held-out
RMSE reductions; :func:`blind_targets` checks the study's targets (an alias pair
scored on its mapped estimate, a drift inside the windows the diagnosis declares
blind counted on a second line); :func:`drift_by_shape` splits the h drifts by
drawn shape; :func:`print_report` prints it all for people.
"""

from __future__ import annotations

from collections import Counter, defaultdict

import numpy as np

__all__ = ["score", "blind_targets", "drift_by_shape", "print_report", "right_first", "score_pairs",
           "print_pairs", "pair_outcome", "member_estimate",
           "truth_estimate", "drift_span", "declared_blind", "outcome"]


def outcome(res: dict) -> str:
    if not res["decidable"]:
        return "undecidable"
    if res["effects"]:
        return res["effects"][0]["name"]
    return "unexplained" if res["unexplained"] else "none"


def _tally(results: list[dict]) -> tuple[dict, dict, list]:
    """Per case: the confusion row, the per-effect counts and errors; and the failed runs."""
    rows = defaultdict(Counter)
    per = defaultdict(lambda: {"n": 0, "first": 0, "named_or_alias": 0, "errors": [], "ratio": [],
                               "n_det": 0, "first_det": 0})
    errors = []
    for r in results:
        c = r["case"]
        if "error" in r:
            errors.append(r)
            continue
        res = r["result"]
        row = {"effect": c["effect"], "null": "none (null)", "push": "push (out of catalog)",
               "constant": f"{c['effect']} at constant speed",
               "invisible": f"{c['effect']} without M_d"}[c["kind"]]
        got = outcome(res)
        rows[row][got] += 1
        if c["kind"] == "effect":
            d = per[c["effect"]]
            d["n"] += 1
            first = res["effects"][0] if res["effects"] else None
            if first and first["name"] == c["effect"] and res["decidable"]:
                d["first"] += 1
                d["errors"].append((first["estimate"] - c["value"]) / abs(c["value"]))
                d["covered"] = d.get("covered", 0) + int(first["ci95"][0] <= c["value"] <= first["ci95"][1])
            named = [e["name"] for e in res["effects"]] + sum((e["aliases"] for e in res["effects"]), [])
            if c["effect"] in named:
                d["named_or_alias"] += 1
            d["ratio"].append(res["augmented_rmse"] / res["nominal_rmse"])
            # the tool's own detection limit for this effect in this recording
            lim = res["limits"].get(c["effect"], {}).get("detectable_above")
            ref = abs(c["value"] - 65.0) if c["effect"] == "rider_mass" else abs(c["value"])
            if lim is not None and ref >= lim:
                d["n_det"] += 1
                d["first_det"] += int(bool(first and first["name"] == c["effect"] and res["decidable"]))
    return rows, per, errors


def score(results: list[dict]) -> dict:
    """Confusion table, per-effect rates, estimate errors and the targets."""
    rows, per, errors = _tally(results)
    n_eff = sum(d["n"] for d in per.values())
    n_first = sum(d["first"] for d in per.values())
    all_err = [e for d in per.values() for e in d["errors"]]
    all_ratio = [x for d in per.values() for x in d["ratio"] if True]
    found_ratio = [x for r in results if "result" in r and r["case"]["kind"] == "effect"
                   and r["result"]["effects"] for x in [r["result"]["augmented_rmse"] / r["result"]["nominal_rmse"]]]
    # the same, split by how far the nominal RMSE stood above the noise floor: the
    # augmented RMSE cannot go below the floor, so from under 2x the floor halving is
    # out of reach by arithmetic, whatever the model
    above_floor = [r["result"]["augmented_rmse"] / r["result"]["nominal_rmse"] for r in results
                   if "result" in r and r["case"]["kind"] == "effect" and r["result"]["effects"]
                   and r["result"]["nominal_rmse"] >= 2.0 * r["result"]["noise_floor"]]
    nulls = [r for r in results if "result" in r and r["case"]["kind"] == "null"]
    null_clean = sum(1 for r in nulls if not r["result"]["effects"])
    pushes = [r for r in results if "result" in r and r["case"]["kind"] == "push"]
    push_ok = sum(1 for r in pushes if r["result"]["unexplained"] and not r["result"]["effects"])
    push_flag = sum(1 for r in pushes if r["result"]["unexplained"])
    inv = [r for r in results if "result" in r and r["case"]["kind"] == "invisible"]
    inv_ok = sum(1 for r in inv if not any(e["name"] == r["case"]["effect"] for e in r["result"]["effects"]))
    const = [r for r in results if "result" in r and r["case"]["kind"] == "constant"]
    const_named = sum(1 for r in const if r["case"]["effect"] in
                      [e["name"] for e in r["result"]["effects"]]
                      + sum((e["aliases"] for e in r["result"]["effects"]), []))
    n_alias_ok = sum(d["named_or_alias"] for d in per.values())
    n_det = sum(d["n_det"] for d in per.values())
    n_first_det = sum(d["first_det"] for d in per.values())
    n_cov = sum(d.get("covered", 0) for d in per.values())
    targets = blind_targets(results)
    targets_before = {
        "right effect first >= 90%": {"value": n_first / n_eff if n_eff else float("nan"),
                                      "met": n_eff > 0 and n_first / n_eff >= 0.9},
        "right effect first >= 90%, among cases above the tool's own detection limit":
            {"value": n_first_det / n_det if n_det else float("nan"),
             "met": n_det > 0 and n_first_det / n_det >= 0.9, "n": n_det},
        "right effect first or among its reported aliases >= 90% (docs/diagnosis.md)":
            {"value": n_alias_ok / n_eff if n_eff else float("nan"),
             "met": n_eff > 0 and n_alias_ok / n_eff >= 0.9},
        "no effect on >= 5 null recordings": {"value": f"{null_clean}/{len(nulls)}",
                                              "met": null_clean >= 5 and null_clean == len(nulls)},
        "estimates within ±25%": {"value": (float(np.mean(np.abs(all_err) <= 0.25)) if all_err else float("nan")),
                                  "met": bool(all_err) and bool(np.all(np.abs(all_err) <= 0.25))},
        "held-out RMSE at least halved where an effect was found":
            {"value": (float(np.mean(np.array(found_ratio) <= 0.5)) if found_ratio else float("nan")),
             "met": bool(found_ratio) and bool(np.all(np.array(found_ratio) <= 0.5))},
        "out-of-catalog push reported unexplained (no name)": {"value": f"{push_ok}/{len(pushes)}",
                                                               "met": len(pushes) > 0 and push_ok == len(pushes)},
    }
    return {"confusion": {k: dict(v) for k, v in rows.items()}, "earlier_targets": targets_before,
            "drift_shapes": drift_by_shape(results),
            "per_effect": {k: {"n": d["n"], "first": d["first"], "named_or_alias": d["named_or_alias"],
                               "n_above_limit": d["n_det"], "first_above_limit": d["first_det"],
                               "median_abs_error": float(np.median(np.abs(d["errors"]))) if d["errors"] else None,
                               "max_abs_error": float(np.max(np.abs(d["errors"]))) if d["errors"] else None,
                               "within_25pct": (float(np.mean(np.abs(d["errors"]) <= 0.25))
                                                if d["errors"] else None),
                               "median_rmse_ratio": float(np.median(d["ratio"])) if d["ratio"] else None}
                           for k, d in per.items()},
            "targets": targets, "push_flagged": f"{push_flag}/{len(pushes)}",
            "ci95_coverage": f"{n_cov}/{n_first}",
            "halved_where_nominal_above_2x_floor": (f"{sum(x <= 0.5 for x in above_floor)}/{len(above_floor)}"),
            "halved_found_cases": f"{sum(x <= 0.5 for x in found_ratio)}/{len(found_ratio)}",
            "invisible_not_named": f"{inv_ok}/{len(inv)}",
            "constant_speed_undecidable": f"{sum(1 for r in const if not r['result']['decidable'])}/{len(const)}",
            "constant_speed_named_or_alias": f"{const_named}/{len(const)}",
            "dropped": [{"case": r["case"]["name"], "error": r["error"]} for r in errors],
            "all_rmse_ratio_median": float(np.median(all_ratio)) if all_ratio else None}


def right_first(case: dict, res: dict) -> bool:
    """The concealed effect named first, or in the reported alias pair of the first name."""
    if not (res["decidable"] and res["effects"]):
        return False
    first = res["effects"][0]
    return first["name"] == case["effect"] or case["effect"] in first.get("aliases", [])


def truth_estimate(case: dict, res: dict) -> dict | None:
    """The estimate and 95 % interval the diagnosis gives for the concealed effect.

    Named first: its own.  In the first name's alias pair: the identified quantity
    mapped to the concealed effect's unit (the diagnosis's ``alias_estimates``, e.g.
    the constant force of a slope expressed as a C_rr).  Otherwise None.
    """
    if not right_first(case, res):
        return None
    first = res["effects"][0]
    if first["name"] == case["effect"]:
        return first
    return first.get("alias_estimates", {}).get(case["effect"])


def drift_span(case: dict) -> tuple[float, float]:
    """Where the drawn drift changes h or leaves it changed, s: a ramp from its start to the
    end, a dip over its length, a sine or a wander over the whole ride."""
    shape = case.get("drift_shape") or {"kind": "sine"}
    if shape["kind"] == "ramp":
        return shape["start"], case["duration"]
    if shape["kind"] == "dip":
        return shape["start"], shape["start"] + shape["length"]
    return 0.0, case["duration"]


def declared_blind(case: dict, res: dict) -> bool:
    """A drift that lies wholly where the diagnosis reported it could not see one
    (``limits.cog_height_drift.blind_windows``), with nothing named: the tool said
    what it cannot see, and the drift is there."""
    if case["effect"] != "cog_height_drift" or res["effects"]:
        return False
    lim = res["limits"].get("cog_height_drift", {})
    wins = lim.get("blind_windows") or []
    a, b = drift_span(case)
    if wins:    # the filter's edges are analysed by no one: the span within the residual's samples
        a, b = max(a, lim["analysed_span"][0]), min(b, lim["analysed_span"][1])
    return any(w0 <= a + 0.25 and b - 0.25 <= w1 for w0, w1 in wins)


def blind_targets(results: list[dict]) -> dict:
    """The blind study's targets (docs/diagnosis.md, section 7): right first ≥ 95 % (an alias pair counts),
    no effect on nulls, the push unexplained, estimates within ±25 % and the held-out
    RMSE halved where the nominal RMSE is ≥ 2× the noise floor (below that the
    augmented RMSE within 1.2× the floor), 95 % intervals covering the truth in
    90-98 % of the cases named right.  A case named by its alias pair is scored on
    the identified quantity mapped to the concealed effect (:func:`truth_estimate`),
    in the estimates and in the coverage."""
    eff = [r for r in results if "result" in r and r["case"]["kind"] == "effect"]
    right = [r for r in eff if right_first(r["case"], r["result"])]
    big = [r for r in eff if r["result"]["nominal_rmse"] >= 2.0 * r["result"]["noise_floor"]]
    small = [r for r in eff if r not in big]

    def est_ok(r):
        e = truth_estimate(r["case"], r["result"])
        return e is not None and abs(e["estimate"] - r["case"]["value"]) <= 0.25 * abs(r["case"]["value"])

    big_est = sum(est_ok(r) for r in big)
    big_half = sum(r["result"]["augmented_rmse"] <= 0.5 * r["result"]["nominal_rmse"] for r in big)
    small_ok = sum(r["result"]["augmented_rmse"] <= 1.2 * r["result"]["noise_floor"] for r in small)
    named = [(r, e) for r in right for e in [truth_estimate(r["case"], r["result"])] if e is not None]
    cov = sum(e["ci95"][0] <= r["case"]["value"] <= e["ci95"][1] for r, e in named)
    nulls = [r for r in results if "result" in r and r["case"]["kind"] == "null"]
    pushes = [r for r in results if "result" in r and r["case"]["kind"] == "push"]
    null_ok = sum(not r["result"]["effects"] for r in nulls)
    push_ok = sum(r["result"]["unexplained"] and not r["result"]["effects"] for r in pushes)
    n = len(eff)
    blind = sum(declared_blind(r["case"], r["result"]) for r in eff)
    return {
        "right effect first (alias pair counts) >= 95%": {"value": f"{len(right)}/{n}",
                                                          "met": n > 0 and len(right) >= 0.95 * n},
        "... or, for a drift wholly inside the windows the diagnosis reports blind, nothing named": {
            "value": f"{len(right) + blind}/{n}", "met": n > 0 and len(right) + blind >= 0.95 * n},
        "no effect on nulls": {"value": f"{null_ok}/{len(nulls)}", "met": null_ok == len(nulls)},
        "out-of-catalog push unexplained, no name": {"value": f"{push_ok}/{len(pushes)}",
                                                     "met": push_ok == len(pushes)},
        "nominal >= 2x floor: estimate within ±25%": {"value": f"{big_est}/{len(big)}",
                                                      "met": big_est == len(big)},
        "nominal >= 2x floor: held-out RMSE at least halved": {"value": f"{big_half}/{len(big)}",
                                                               "met": big_half == len(big)},
        "nominal < 2x floor: augmented RMSE within 1.2x floor": {"value": f"{small_ok}/{len(small)}",
                                                                 "met": small_ok == len(small)},
        "95% intervals cover the truth in 90-98% of named cases (alias pairs mapped)": {
            "value": f"{cov}/{len(named)}", "met": bool(named) and 0.90 <= cov / len(named) <= 0.98},
    }


def drift_by_shape(results: list[dict]) -> dict:
    """Per drawn drift shape: cases, named first, estimate errors, and whether the
    reported windows overlap the true change (ramp and dip: [start, start + length])."""
    out = {}
    for r in results:
        c = r["case"]
        if "result" not in r or c["kind"] != "effect" or c["effect"] != "cog_height_drift":
            continue
        shape = c.get("drift_shape") or {"kind": "sine"}
        d = out.setdefault(shape["kind"], {"n": 0, "first": 0, "errors": [], "windows_hit": 0, "windows_n": 0,
                                           "nominal_over_floor": []})
        res = r["result"]
        d["n"] += 1
        d["nominal_over_floor"].append(res["nominal_rmse"] / res["noise_floor"])
        if right_first(c, res):
            d["first"] += 1
            d["errors"].append((res["effects"][0]["estimate"] - c["value"]) / c["value"])
            if shape["kind"] in ("ramp", "dip"):
                a, b = shape["start"], shape["start"] + shape["length"]
                d["windows_n"] += 1
                d["windows_hit"] += int(any(w0 <= b and w1 >= a for w0, w1 in res["windows"]))
    for d in out.values():
        errs = np.abs(d.pop("errors"))
        ratios = d.pop("nominal_over_floor")
        d["median_abs_error"] = float(np.median(errs)) if errs.size else None
        d["max_abs_error"] = float(np.max(errs)) if errs.size else None
        d["nominal_over_floor_min"] = float(np.min(ratios))
    return out


def print_report(summary: dict, out=print) -> None:
    """The confusion table and the targets, as text."""
    conf = summary["confusion"]
    cols = sorted({c for row in conf.values() for c in row})
    w = max(len(r) for r in conf) if conf else 10
    out("confusion table: rows = concealed truth, columns = what diagnose named first")
    out(" " * (w + 2) + "  ".join(f"{c[:12]:>12}" for c in cols))
    for r in sorted(conf):
        out(f"{r:<{w}}  " + "  ".join(f"{conf[r].get(c, 0):>12d}" for c in cols))
    out("")
    out(f"{'effect':<24} {'n':>3} {'first':>5} {'named/alias':>11} {'>limit':>6} {'first':>5} "
        f"{'med|err|':>9} {'max|err|':>9} {'≤25%':>5} {'RMSE after/before':>17}")
    for k, d in summary["per_effect"].items():
        fmt = lambda v, f: "—" if v is None else format(v, f)   # noqa: E731
        out(f"{k:<24} {d['n']:>3} {d['first']:>5} {d['named_or_alias']:>11} "
            f"{d['n_above_limit']:>6} {d['first_above_limit']:>5} "
            f"{fmt(d['median_abs_error'], '9.1%')} {fmt(d['max_abs_error'], '9.1%')} "
            f"{fmt(d['within_25pct'], '5.0%')} {fmt(d['median_rmse_ratio'], '17.2f')}")
    out("")
    out(f"effects concealed without M_d that cannot be revealed, not named: {summary['invisible_not_named']}")
    out(f"constant-speed recordings (swaying rider): declared undecidable "
        f"{summary['constant_speed_undecidable']}, right effect named or aliased "
        f"{summary['constant_speed_named_or_alias']}")
    out(f"out-of-catalog push flagged unexplained: {summary['push_flagged']}")
    out(f"true value inside the reported 95% interval (correct names): {summary['ci95_coverage']}")
    out(f"held-out RMSE halved: {summary['halved_found_cases']} recordings with an effect named; "
        f"{summary['halved_where_nominal_above_2x_floor']} of those whose nominal RMSE was at least "
        "twice the noise floor (below that, halving is out of reach)")
    if summary["dropped"]:
        out(f"dropped (simulation failed): {summary['dropped']}")
    out("")
    out("h drift by drawn shape (windows: the reported windows overlap the true change):")
    for k, d in summary.get("drift_shapes", {}).items():
        err = "—" if d["median_abs_error"] is None else f"{d['median_abs_error']:.1%} / {d['max_abs_error']:.1%}"
        win = f"{d['windows_hit']}/{d['windows_n']}" if d["windows_n"] else "—"
        out(f"  {k:<8} named first {d['first']}/{d['n']}; |error| median / max {err}; windows {win}; "
            f"smallest nominal RMSE {d['nominal_over_floor_min']:.1f}x the floor")
    out("")
    out("targets:")
    for k, v in summary["targets"].items():
        val = v["value"]
        val = f"{val:.1%}" if isinstance(val, float) else val
        out(f"  {'MET    ' if v['met'] else 'NOT MET'}  {k}: {val}")


# --- pairs ----------------------------------------------------------------------------------
#: Pairs that are one constant force along the road while the speed keeps one sign
#: (docs/diagnosis.md): the recording cannot split them, so they are scored apart from the target.
ALIAS_FAMILIES = {frozenset({"rolling_resistance", "road_slope"})}


def member_estimate(res: dict, member: str) -> dict | None:
    """The named item giving ``member``'s estimate: named itself, or a named effect with
    ``member`` among its aliases and a mapped estimate (``alias_estimates``); else None."""
    for e in res["effects"]:
        if e["name"] == member:
            return e
    for e in res["effects"]:
        if member in e.get("aliases", []) and member in e.get("alias_estimates", {}):
            return {"name": e["name"], **e["alias_estimates"][member]}
    return None


def pair_outcome(case: dict, res: dict) -> dict:
    """One pair scored: each member named (and its relative error), the false extras, and
    the pass rule (both named, each within ±25 %, nothing else named;
    ``unexplained`` exactly when the pair holds the push)."""
    members = list(case["effects"])
    push = bool(case.get("push"))
    found = {m: member_estimate(res, m) if res["decidable"] else None for m in members}
    used = {found[m]["name"] for m in members if found[m]}
    extras = [e["name"] for e in res["effects"] if e["name"] not in used] if res["decidable"] else []
    err = {m: (None if found[m] is None else (found[m]["estimate"] - case["effects"][m]) / abs(case["effects"][m]))
           for m in members}
    n_right = sum(f is not None for f in found.values()) + int(push and res["unexplained"])
    n_all = len(members) + int(push)
    ok = (n_right == n_all and not extras and all(abs(e) <= 0.25 for e in err.values() if e is not None)
          and bool(res["unexplained"]) == push)
    ratios = case.get("twin_ratio") or {}
    above = all((ratios.get(m) or 0.0) >= 2.0 for m in members)
    return {"family": case["family"], "right": n_right, "of": n_all, "extras": extras, "errors": err,
            "pass": ok, "above_2x": above, "ratios": ratios, "alias_family": frozenset(members) in ALIAS_FAMILIES,
            "unexplained": bool(res["unexplained"]), "verdict": res["verdict"], "name": case["name"]}


def score_pairs(results: list[dict]) -> dict:
    """The tallies over the pair recordings: by family, right-both, right-one, false
    extras and estimate errors; the target (pairs whose members each stand ≥ 2× the floor
    with the other known: pass on ≥ 90 %), alias families apart."""
    rows = [pair_outcome(r["case"], r["result"]) for r in results if "result" in r and r["case"]["kind"] == "pair"]
    fams: dict = {}
    for o in rows:
        d = fams.setdefault(o["family"], {"n": 0, "both": 0, "one": 0, "none": 0, "extras": 0, "pass": 0,
                                          "errors": []})
        d["n"] += 1
        d["both" if o["right"] == o["of"] else "one" if o["right"] else "none"] += 1
        d["extras"] += len(o["extras"])
        d["pass"] += int(o["pass"])
        d["errors"] += [abs(e) for e in o["errors"].values() if e is not None]
    for d in fams.values():
        e = d.pop("errors")
        d["median_abs_error"] = float(np.median(e)) if e else None
        d["max_abs_error"] = float(np.max(e)) if e else None
    big = [o for o in rows if o["above_2x"] and not o["alias_family"]]
    small = [o for o in rows if not o["above_2x"] and not o["alias_family"]]
    alias = [o for o in rows if o["alias_family"]]
    fails = [{k: (sorted(v) if isinstance(v, frozenset) else v) for k, v in o.items()}
             for o in big if not o["pass"]]
    return {"n": len(rows), "families": fams,
            "right_both": sum(o["right"] == o["of"] for o in rows),
            "right_one": sum(0 < o["right"] < o["of"] for o in rows),
            "right_none": sum(o["right"] == 0 for o in rows),
            "false_extras": sum(len(o["extras"]) for o in rows),
            "target_above_2x": {"value": f"{sum(o['pass'] for o in big)}/{len(big)}",
                                "met": bool(big) and sum(o["pass"] for o in big) >= 0.9 * len(big)},
            "below_2x_pass": f"{sum(o['pass'] for o in small)}/{len(small)}",
            "below_2x_false_extras": sum(len(o["extras"]) for o in small),
            "alias_families": f"{sum(o['right'] >= 1 and not o['extras'] for o in alias)}/{len(alias)} "
                              "named as one constant force, nothing else",
            "failures_above_2x": fails}


def print_pairs(summary: dict, out=print) -> None:
    """The pair tallies as text."""
    if not summary["n"]:
        return
    out("")
    out(f"pairs: {summary['n']} recordings; right both {summary['right_both']}, right one "
        f"{summary['right_one']}, none {summary['right_none']}; false extras {summary['false_extras']}")
    out(f"{'family':<48} {'n':>3} {'both':>4} {'one':>4} {'none':>4} {'extra':>5} {'pass':>4} {'med|err|':>9} {'max|err|':>9}")
    fmt = lambda v: "—" if v is None else f"{v:9.1%}"   # noqa: E731
    for k in sorted(summary["families"]):
        d = summary["families"][k]
        out(f"{k:<48} {d['n']:>3} {d['both']:>4} {d['one']:>4} {d['none']:>4} {d['extras']:>5} {d['pass']:>4} "
            f"{fmt(d['median_abs_error'])} {fmt(d['max_abs_error'])}")
    t = summary["target_above_2x"]
    out(f"  {'MET    ' if t['met'] else 'NOT MET'}  pairs with each member >= 2x the floor (the other known): "
        f"both named, each within ±25 %, nothing else, >= 90 %: {t['value']}")
    out(f"  below 2x the floor: pass {summary['below_2x_pass']}, false extras {summary['below_2x_false_extras']}")
    out(f"  rolling resistance + slope (one force while the speed keeps one sign): {summary['alias_families']}")
    for f in summary["failures_above_2x"]:
        ratios = ", ".join(f"{k} {v:.1f}x" if v is not None else f"{k} ?" for k, v in f["ratios"].items())
        errs = ", ".join(f"{k} {v:+.0%}" if v is not None else f"{k} missed" for k, v in f["errors"].items())
        out(f"    {f['name']} {f['family']} ({ratios}): {errs}; extras {f['extras']}; {f['verdict']}")
