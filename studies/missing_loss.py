#!/usr/bin/env python
"""The loss the rides ask for beyond a tyre's: candidates tested against the shared rides.

    nice python studies/missing_loss.py spin
    nice python studies/missing_loss.py fits [--only SUBSTR] [--pairs v9] [--json OUT]

``spin``: every shared ride's free-spin moments (``rides/grids/spin.free_spin``: the
wheel off the ground, no tyre on the road, no rider to carry) where the controller
holds its top duty (PWM ≥ 95 %) and the speed is steady: the battery power there is
the drivetrain's no-load loss at that wheel speed (plus the no-load current's copper
loss), with the drag torque P/ω it stands for and the tyre force P/v it would alias in
the balance's |v| column, as a share of the ride's true weight (``meta.csv``).

``fits``: each comparison of ``scripts/tables/balance_heldout.py`` fitted three ways,
the candidate set of ``rides/balance/design.py`` otherwise unchanged:

- ``as_is``: the balance as it stands;
- ``speed_loss``: the |v| column (C_rr·m·g·|v|) allowed up to C_rr 0.15, i.e. a loss
  proportional to speed beyond a tyre's 0.05 (a motor's hysteresis loss T_h·|ω| has
  this column exactly);
- ``omega2``: a b·ω² loss added as a candidate (the motor's eddy-current loss, viscous
  friction, or a tyre whose C_rr grows with speed: the same column up to m·g),
  0 ≤ b ≤ 1 N·m·s/rad;
- ``omega2_spin``: the same, 0 ≤ b ≤ 0.2 (the Apex free spin's b, rounded up);
- ``omega2_last``: the same, offered only after the balance's own two passes;
- ``wind``: a steady wind from the GPS heading (two columns v|v|·cos h, v|v|·sin h);
- ``true_mass``: the true total mass handed to the balance (a diagnosis of how much of
  the edge is the mass the log's energy balance finds);
- ``unsigned``: on a log whose current is never negative, only the rows where the ride
  surely draws power (a current channel that reports the magnitude).

Printed per comparison: the selected model's held-out error and its change against
``as_is``, the terms on a plausible edge (``design.on_bound`` at 1e-3 of the range),
the |v| column's force beyond C_rr 0.05 (N) and the b found.  The shared rides are the
project's tuning rides: these figures are tuning figures.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import json
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SHARED = Path("/work/shared/data") if Path("/work/shared/data").is_dir() else ROOT.parent / "shared" / "data"
G = 9.81
EDGE_REL = 1e-3


def _heldout_module():
    spec = importlib.util.spec_from_file_location("balance_heldout", ROOT / "scripts" / "tables" / "balance_heldout.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# ---------------------------------------------------------------------------- free spin
def spin_table() -> list[dict]:
    """Steady top-duty free-spin stretches of every shared ride."""
    from euc_sim.rides.grids.spin import spin_rows
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import read_spec

    out = []
    for meta in sorted((SHARED / "euc_core").glob("trips/*/*/*/meta.csv")):
        with open(meta, newline="") as fh:
            row = next(csv.DictReader(fh))
        log = read_log(meta.parent / f"{meta.parent.name}.csv")
        d = log.data
        spin = spin_rows(d)
        if not spin.any() or "pwm" not in d:
            continue
        spec = read_spec(SHARED / "euc_core" / "specs" / f"{row['wheel']}.csv")
        R = float(spec.radius)
        v, P, pwm, t = (d[c].to_numpy(float) for c in ("v", "power", "pwm", "t"))
        v = np.abs(v)
        dv = np.gradient(v, t)
        steady = spin & (pwm >= 95) & (np.abs(dv) < 2.0) & (v > 5.0)
        weight = (float(row["rider_weight"]) + float(spec.wheel_mass)) * G
        if not steady.any():
            out.append({"ride": f"{row['wheel']}/{meta.parent.name}", "spin_rows": int(spin.sum()),
                        "steady_rows": 0})
            continue
        p, w = P[steady], v[steady] / R
        out.append({"ride": f"{row['wheel']}/{meta.parent.name}", "spin_rows": int(spin.sum()),
                    "steady_rows": int(steady.sum()), "v": float(np.median(v[steady])),
                    "omega": float(np.median(w)), "P": float(np.median(p)),
                    "P_iqr": [float(np.percentile(p, 25)), float(np.percentile(p, 75))],
                    "torque": float(np.median(p / w)), "force": float(np.median(p / v[steady])),
                    "crr_equivalent": float(np.median(p / v[steady]) / weight),
                    "b_if_eddy": float(np.median(p / w ** 2)), "R": R})
    return out


# ---------------------------------------------------------------------------- variants
VARIANTS = ("as_is", "speed_loss", "omega2", "omega2_spin", "omega2_last", "wind", "unsigned",
            "true_mass")
#: The b·ω² bound of ``omega2_spin``: the Apex free spin's no-load loss read as b·ω²
#: (2.88 kW at 132 rad/s: b = 0.166 N·m·s/rad), rounded up.
B_SPIN = 0.2


def _omega2_on(b_max: float = 1.0):
    """Add the b·ω² candidate to the balance, 0 ≤ b ≤ ``b_max`` (a patch for this study only)."""
    from euc_sim.rides.balance import design, fit

    design.CANDIDATES["wheel_bearing_friction"] = ("b", "N·m·s/rad", "b·ω² loss", "spin", "rad²/s²")
    design.PLAUSIBLE["wheel_bearing_friction"] = (0.0, b_max, "N·m·s/rad")
    design.BOUNDS["wheel_bearing_friction"] = (0.0, b_max)
    fit._START["wheel_bearing_friction"] = 0.0
    old = design._regressors

    def regressors(sig, L1, frac):
        cols, cands, aliases, notes = old(sig, L1, frac)
        cols["spin"] = L1((sig.raw["v"].to_numpy() / sig.assumptions.R) ** 2)
        return cols, cands + ["wheel_bearing_friction"], aliases, notes
    design._regressors = regressors


def _wind_on():
    """Add a steady wind from the GPS heading h (a patch for this study only).

    Drag k·(v + u)|v + u| with u = w_N·cos h + w_E·sin h the headwind, to first order in
    u adds 2k·u·v|v|: two columns v|v|·cos h and v|v|·sin h with free coefficients
    c = 2k·w (kg/s; |c| ≤ 2·0.6·8, a wind up to 8 m/s at C_dA 1 m²), offered together.
    """
    from euc_sim.rides.balance import design, fit

    for n, col in (("wind_north", "wind_n"), ("wind_east", "wind_e")):
        design.CANDIDATES[n] = ("c", "kg/s", "2k·wind", col, "m²/s²")
        design.PLAUSIBLE[n] = (-9.6, 9.6, "kg/s")
        design.BOUNDS[n] = (-9.6, 9.6)
        fit._START[n] = 0.0
    old = design._regressors

    def regressors(sig, L1, frac):
        cols, cands, aliases, notes = old(sig, L1, frac)
        if "gps_heading" in sig.raw:
            h = sig.raw["gps_heading"].to_numpy(float)           # rad on the grid
            v = sig.raw["v"].to_numpy(float)
            ok = np.isfinite(h)
            cols["wind_n"] = L1(np.where(ok, v * np.abs(v) * np.cos(np.nan_to_num(h)), 0.0))
            cols["wind_e"] = L1(np.where(ok, v * np.abs(v) * np.sin(np.nan_to_num(h)), 0.0))
            cands = cands + ["wind_north", "wind_east"]
        return cols, cands, aliases, notes
    design._regressors = regressors


def _unsigned_on(margin: float = 10.0):
    """On a log whose battery current is never negative, fit and score only driving rows.

    Such a log reports the current's magnitude: braking reads as drawing, and the signed
    balance can only meet it with more loss.  Kept: rows whose floor of the true battery
    power (inertial power plus the least plausible rolling and drag, no grade) has a
    negative part averaging above −``margin`` W over the filters' reach (a patch for
    this study only).
    """
    import dataclasses

    from scipy.ndimage import uniform_filter1d

    from euc_sim.rides.balance import analysis, design
    from euc_sim.rides.grids.signals import window_samples

    old = design.balance_design

    def balance_design(sig, *a, **k):
        d = old(sig, *a, **k)
        cur = sig.raw["current"].to_numpy(float) if "current" in sig.raw else None
        if cur is None or (cur < -0.5).mean() > 0.005:
            return d
        X = d.columns_full
        floor = (X["inertia"] + design.PLAUSIBLE["rolling_resistance"][0] * X["rolling"]
                 + design.PLAUSIBLE["aerodynamic_drag"][0] * X["drag"]).to_numpy(float)
        n = len(d.kernel) + window_samples(design.PRE_WINDOW, sig.rate, min(2, sig.polyorder))
        keep = uniform_filter1d(np.minimum(floor, 0.0), n, mode="nearest") >= -margin
        return dataclasses.replace(d, use=d.use & keep,
                                   notes=d.notes + ("unsigned current: driving rows only",))
    design.balance_design = balance_design
    analysis.balance_design = balance_design


def _last_pass(term: str):
    """Offer ``term`` only after both passes of the selection, as a third pass of the same rule."""
    from euc_sim.rides.balance import crossride
    from euc_sim.stats import forward_select

    old = crossride.select_effects

    def select(design, candidates):
        names, history, blocked = old(design, [c for c in candidates if c != term])
        if term not in candidates:
            return names, history, blocked
        scores = crossride._HeldoutScores(design)
        kept, extra = forward_select(lambda n: scores.score(n, "plausible"),
                                     list(crossride.NOMINAL) + names, [term], crossride.MIN_GAIN)
        return kept[len(crossride.NOMINAL):], history + extra[1:], blocked
    crossride.select_effects = select


_TRUTH: dict = {}


def _true_mass_on():
    """Hand the balance the true total mass (rider + wheel, ``meta.csv`` and the spec) in place
    of the one the log's energy balance finds, m_eq shifted alike (a diagnosis, not a fit:
    only the shared rides' truths allow it).  WheelLog logs have no truth and keep theirs."""
    from euc_sim.rides.grids import signals

    old = signals.with_found_values

    def with_truth(assumptions, spec, total_mass):
        m = _TRUTH.get("mass")
        if m is None:
            return old(assumptions, spec, total_mass)
        found = (total_mass or {}).get("estimate")
        eq = ((total_mass or {}).get("equivalent_mass") or {}).get("estimate")
        shift = (eq - found) if (eq is not None and found is not None) else 0.0
        return old(assumptions, spec, {"estimate": m, "equivalent_mass": {"estimate": m + shift}})
    signals.with_found_values = with_truth


def _truth_of(case: dict) -> float | None:
    """Rider weight (``meta.csv``) + the spec's net weight, kg, or None."""
    meta = Path(case["log"]).parent / "meta.csv"
    if not meta.exists() or case["spec"] is None:
        return None
    from euc_sim.rides.source.spec import read_spec

    with open(meta, newline="") as fh:
        row = next(csv.DictReader(fh))
    return float(row["rider_weight"]) + float(read_spec(case["spec"]).wheel_mass)


def run_fits(variant: str, only: str | None, pairs: tuple) -> list[dict]:
    from euc_sim.rides.balance import design

    if variant == "speed_loss":
        design.BOUNDS["rolling_resistance"] = (0.0, 0.15)
        design.PLAUSIBLE["rolling_resistance"] = (0.005, 0.15, "1")
    elif variant == "omega2":
        _omega2_on()
    elif variant == "true_mass":
        _true_mass_on()
    elif variant == "unsigned":
        _unsigned_on()
    elif variant == "wind":
        _wind_on()
    elif variant == "omega2_spin":
        _omega2_on(B_SPIN)
    elif variant == "omega2_last":
        _omega2_on()
        _last_pass("wheel_bearing_friction")
    bh = _heldout_module()
    rows = []
    for case in bh.cases(SHARED, pairs):
        if only and only not in case["label"]:
            continue
        print(f"... {variant} {case['label']}", file=sys.stderr, flush=True)
        _TRUTH["mass"] = _truth_of(case)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = bh.one(case, 10, 0)
        est = r["augmented_estimates"]
        crr = est.get("rolling_resistance", 0.0) if "rolling_resistance" in r["accepted"] else 0.0
        r["edge"] = edges(r, variant)
        r["excess_force"] = max(crr - 0.05, 0.0) * r["total_mass"] * G
        r["b"] = est.get("wheel_bearing_friction", 0.0) if "wheel_bearing_friction" in r["accepted"] else 0.0
        r["variant"] = variant
        rows.append(r)
    return rows


#: Each variant's bounds that differ from ``design.BOUNDS``.
VARIANT_BOUNDS = {"speed_loss": {"rolling_resistance": (0.0, 0.15)},
                  "omega2": {"wheel_bearing_friction": (0.0, 1.0)},
                  "omega2_spin": {"wheel_bearing_friction": (0.0, B_SPIN)},
                  "omega2_last": {"wheel_bearing_friction": (0.0, B_SPIN)},
                  "wind": {"wind_north": (-9.6, 9.6), "wind_east": (-9.6, 9.6)}}


def edges(row: dict, variant: str) -> list[str]:
    """The accepted terms of ``row`` on an edge of the variant's bounds (``design.on_bound``
    at 1e-3 of the range, or of 1 where the range is narrower: C_rr from 0.049)."""
    from euc_sim.rides.balance import design

    bounds = {**design.BOUNDS, **VARIANT_BOUNDS.get(variant, {})}
    out = []
    for k in row["accepted"]:
        x, (lo, hi) = row["augmented_estimates"].get(k), bounds.get(k, (-np.inf, np.inf))
        tol = EDGE_REL * max(hi - lo, 1.0)
        if x is not None and (x >= hi - tol or (lo != 0.0 and x <= lo + tol)):
            out.append(k)
    return out


#: Letters for the terms in the per-comparison table.
_ABBR = {"rolling_resistance": "R", "aerodynamic_drag": "D", "wheel_bearing_friction": "B",
         "current_lag": "L", "copper_loss": "C", "drivetrain_idle_loss": "I"}


def compare(runs: dict[str, list[dict]]) -> str:
    """Markdown: per comparison, ``as_is``'s held-out error (W) and each variant's change (%),
    with the terms on an edge as letters (:data:`_ABBR`), ΔF (N) and b where kept."""
    base = {r["label"]: r for r in runs["as_is"]}
    out = ["| comparison | " + " | ".join(runs) + " |", "|---|" + "---|" * len(runs)]
    for label, b in base.items():
        cells = []
        for v, rows in runs.items():
            r = next((x for x in rows if x["label"] == label), None)
            if r is None:
                cells.append("–")
                continue
            r["edge"] = edges(r, v)
            ed = "".join(_ABBR.get(t, t) for t in r["edge"]) or "—"
            ch = 100 * (r["selected"] / b["selected"] - 1)
            head = f"{r['selected']:.1f}" if v == "as_is" else f"{ch:+.1f}"
            head = "0.0" if head in ("+0.0", "-0.0") else head
            extra = (f" ΔF {r['excess_force']:.0f}" if r["excess_force"] else "") + (
                f" b {r['b']:.2f}" if r["b"] else "")
            cells.append(f"{head} {ed}{extra}")
        out.append(f"| {label.replace(' halves', ' h')} | " + " | ".join(cells) + " |")
    for v, rows in runs.items():
        n = len(rows)
        ch = [100 * (r["selected"] / base[r["label"]]["selected"] - 1) for r in rows]
        out.append(f"\n{v}: a term on an edge {sum(bool(r['edge']) for r in rows)}/{n}; rule (5 %) "
                   f"{sum(r['rule_met'] for r in rows)}/{n}; held-out worse by > 2 % on "
                   f"{sum(c > 2 for c in ch)}, better by > 5 % on {sum(c < -5 for c in ch)}")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("spin", "fits", "table"))
    ap.add_argument("--variant", choices=VARIANTS, default=None,
                    help="fit one variant (each in its own process: the patches are global)")
    ap.add_argument("--only", default=None)
    ap.add_argument("--pairs", default="v9")
    ap.add_argument("--json", default=None, help="fits: write rows here; table: the stem they were written to")
    a = ap.parse_args(argv)
    if a.what == "spin":
        for r in spin_table():
            print(json.dumps(r))
        return 0
    if a.what == "fits":
        rows = run_fits(a.variant or "as_is", a.only, tuple(w for w in a.pairs.split(",") if w))
        if a.json:
            Path(a.json).write_text(json.dumps(rows))
        return 0
    runs = {v: json.loads(Path(f"{a.json}.{v}.json").read_text()) for v in VARIANTS
            if Path(f"{a.json}.{v}.json").exists()}
    print(compare(runs))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
