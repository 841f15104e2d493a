"""ROC of the diagnosis's acceptance rule: null recordings against weak true effects.

Reads the folders written by ``scripts/tables/blind_study.py`` (a study: ``caseNNN.truth.json``
and ``caseNNN.diagnosis.json``; a calibration, ``--calibrate``: ``nullNNN.diagnosis.json``)
and, for every recording, the statistics of the candidate the first selection step
acted on (the best BIC not refused on physics, the diagnosis JSON's ``history``): its
BIC drop below the nominal model, its |θ|/se and its held-out RMSE gain.

The positives are the concealed effects whose nominal held-out RMSE is below twice
the noise floor ("weak"), counted when that candidate is the concealed effect or its
constant-force alias (rolling resistance and road slope, docs/diagnosis.md); the negatives
are the null recordings (and the effects concealed where they cannot be revealed,
``invisible``).  For each rule (a threshold on one statistic, the other two at their
values), prints how many nulls and how many weak effects it would accept at step 1.

Usage::

    python scripts/tables/acceptance_roc.py --nulls blind/cal7 blind/cal21 --study blind/s7 blind/s21 blind/s22

The selection after step 1, the column rebuilds and the verdict are not replayed: a
rule found here is checked by rerunning the study with it.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from blind_scoring import ALIAS_FAMILIES

STAT_REASONS = ("BIC drop", "held-out RMSE gain", "|θ|/se")


def first_step(history: list[dict]) -> dict:
    """The candidate the first selection step judged on its statistics, and those statistics.

    That is the best-BIC trial not refused on physics (sign, range): a trial refused
    only by the thresholds (BIC drop, held-out gain, |θ|/se) is the one a different
    rule would have accepted.

    Parameters
    ----------
    history : list of dict
        A diagnosis JSON's ``history``.

    Returns
    -------
    dict
        ``name`` (None when every judged trial was refused on physics), ``bic_drop``,
        ``t`` (|θ|/se), ``cv_gain`` (fraction) and ``accepted`` (bool).
    """
    none = {"name": None, "bic_drop": 0.0, "t": 0.0, "cv_gain": 0.0, "accepted": False}
    if len(history) < 2:
        return none
    base, step = history[0]["trials"][0]["bic"], history[1]
    why = {}
    for part in step["reason"].removeprefix("accepted").strip(" ()").removeprefix("refused before it:").split(" | "):
        name, _, reasons = part.strip().partition(": ")
        why[name] = [w for w in reasons.split("; ") if w]
    for d in step["trials"]:          # best BIC first
        if "t" not in d:
            break
        if d["name"] == step["chosen"] and step["accepted"]:
            physics = False
        else:
            physics = any(not w.startswith(STAT_REASONS) for w in why.get(d["name"], []))
        if not physics:
            return {"name": d["name"], "bic_drop": base - d["bic"], "t": d["t"], "cv_gain": d["cv_gain"],
                    "accepted": bool(step["accepted"] and d["name"] == step["chosen"])}
    return none


def load(folder: Path) -> list[dict]:
    """Every diagnosed recording of a folder: kind, concealed effect, weak or not, first step."""
    rows = []
    for path in sorted(folder.glob("*.diagnosis.json")):
        d = json.loads(path.read_text())
        stem = path.name.removesuffix(".diagnosis.json")
        truth = folder / f"{stem}.truth.json"
        case = json.loads(truth.read_text())["case"] if truth.exists() else {"kind": "null", "effect": None}
        if case["kind"] not in ("null", "effect", "invisible"):
            continue
        fs = first_step(d["history"])
        right = fs["name"] is not None and (fs["name"] == case["effect"]
                                            or frozenset({fs["name"], case["effect"]}) in ALIAS_FAMILIES)
        rows.append({"where": f"{folder.name}/{stem}", "kind": case["kind"], "effect": case["effect"],
                     "ratio": d["nominal_rmse"] / d["noise_floor"], "right": right,
                     "named": [e["name"] for e in d["effects"]], **fs})
    return rows


def passes(r: dict, bic: float, t: float, cv: float) -> bool:
    """Would the first step accept this recording's candidate under (bic, t, cv)?"""
    return r["name"] is not None and r["bic_drop"] >= bic and r["t"] >= t and r["cv_gain"] >= cv


def table(neg: list[dict], pos: list[dict], rules: list[tuple[float, float, float]]) -> list[str]:
    """Rows of the ROC: for each rule, nulls accepted and weak true effects accepted right."""
    out = [f"{'BIC drop':>8} {'|θ|/se':>6} {'cv gain':>7} | {'nulls accepted':>14} | {'weak right':>10}"]
    for b, t, c in rules:
        fa = sum(passes(r, b, t, c) for r in neg)
        tp = sum(passes(r, b, t, c) and r["right"] for r in pos)
        out.append(f"{b:>8.1f} {t:>6.1f} {c:>7.2f} | {fa:>6d}/{len(neg):<7d} | {tp:>4d}/{len(pos):<5d}")
    return out


def single(neg: list[dict], pos: list[dict], key: str) -> str:
    """One statistic alone (the others unconstrained): its largest value on the negatives,
    and the weak true effects named right above it."""
    top = max(r[key] for r in neg if r["name"] is not None)
    tp = sum(r["right"] and r["name"] is not None and r[key] > top for r in pos)
    return f"  {key:<8} alone: largest on negatives {top:6.2f}; weak right above it {tp}/{len(pos)}"


def frontier(neg: list[dict], pos: list[dict]) -> list[str]:
    """Rules of a grid (BIC drop, |θ|/se, held-out gain) that accept no negative, the most
    weak true effects first; with each, how close the nearest negative came (the least,
    over negatives, of the largest shortfall of a statistic relative to its threshold's
    step: 1 = one grid step away)."""
    grid_b, grid_t, grid_c = np.arange(-2.0, 20.5, 0.5), np.arange(2.0, 8.25, 0.25), np.arange(-0.05, 0.16, 0.01)
    steps = np.array([0.5, 0.25, 0.01])
    found = []
    for b in grid_b:
        for t in grid_t:
            for c in grid_c:
                if any(passes(r, b, t, c) for r in neg):
                    continue
                tp = sum(passes(r, b, t, c) and r["right"] for r in pos)
                gap = min(max((np.array([b, t, c]) - [r["bic_drop"], r["t"], r["cv_gain"]]) / steps)
                          for r in neg if r["name"] is not None)
                found.append((tp, gap, b, t, c))
    found.sort(key=lambda x: (-x[0], -x[1]))
    return [f"  BIC drop >= {b:4.1f}, |θ|/se >= {t:4.2f}, gain >= {c:5.2f}: weak right {tp}/{len(pos)}, "
            f"nearest negative {gap:.1f} grid steps" for tp, gap, b, t, c in found[:12]]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nulls", nargs="+", default=[], help="calibration folders (null recordings)")
    ap.add_argument("--study", nargs="+", default=[], help="blind-study folders")
    args = ap.parse_args(argv)
    missing = [f for f in args.nulls + args.study if not Path(f).is_dir()]
    if missing:
        print(f"acceptance_roc: {missing[0]}: no such folder (expected a blind_study.py --out folder)",
              file=sys.stderr)
        return 2
    rows = [r for f in args.nulls + args.study for r in load(Path(f))]
    neg = [r for r in rows if r["kind"] in ("null", "invisible")]
    pos = [r for r in rows if r["kind"] == "effect" and r["ratio"] < 2.0]
    if not neg or not pos:
        print("acceptance_roc: need null recordings (--nulls) and weak effects (--study)", file=sys.stderr)
        return 2
    print(f"{len(neg)} negatives (nulls, invisible effects), {len(pos)} weak true effects (< 2x floor)")
    for name, rs in (("negatives", neg), ("weak true", pos)):
        for k in ("bic_drop", "t", "cv_gain"):
            v = np.array([r[k] for r in rs])
            print(f"  {name:<10} {k:<8} max {v.max():7.2f}  p90 {np.percentile(v, 90):7.2f}  "
                  f"median {np.median(v):7.2f}")
    print("\nweak true effects:")
    for r in sorted(pos, key=lambda r: -r["bic_drop"]):
        print(f"  {r['where']:<22} {r['effect']:<20} {r['ratio']:4.2f}x  step 1: {str(r['name']):<20} "
              f"BIC drop {r['bic_drop']:6.1f}  |θ|/se {r['t']:5.1f}  cv gain {r['cv_gain']:5.2f}  "
              f"right {r['right']!s:<5}  named {','.join(r['named']) or '-'}")
    print("\nnegatives, strongest BIC drop first:")
    for r in sorted(neg, key=lambda r: -r["bic_drop"])[:8]:
        print(f"  {r['where']:<22} {r['kind']:<9} step 1: {str(r['name']):<20} BIC drop {r['bic_drop']:6.1f}  "
              f"|θ|/se {r['t']:5.1f}  cv gain {r['cv_gain']:5.2f}  named {','.join(r['named']) or '-'}")
    rules = [(b, 4.0, 0.08) for b in (13.5, 12, 10, 8, 6, 5, 4, 2)] + [(10, t, 0.08) for t in (3.0, 2.0)] \
        + [(10, 4.0, c) for c in (0.05, 0.0)] + [(b, 3.0, 0.05) for b in (10, 6, 4)] \
        + [(13.5, 0.0, -1.0), (10, 0.0, -1.0), (2, 2.0, 0.0)]
    print()
    print("\n".join(table(neg, pos, rules)))
    print("\none statistic alone, above every negative:")
    for group, test in (("all candidates", lambda r: True),
                        ("cog_height_drift", lambda r: r["name"] == "cog_height_drift"),
                        ("other candidates", lambda r: r["name"] not in (None, "cog_height_drift"))):
        n_g, p_g = [r for r in neg if test(r)], [r for r in pos if test(r)]
        print(f" {group}: {len(n_g)} negatives, {len(p_g)} weak true effects")
        for key in ("bic_drop", "t", "cv_gain"):
            if n_g and p_g:
                print(single(n_g, p_g, key))
    print("\nbest rules with no negative accepted, and their nearest negative (grid search):")
    print("\n".join(frontier(neg, pos)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
