"""Known effects hidden in the shared EUC World rides: does ``ride CLEAN --compare CONCEALED`` name them? Written up in docs/concealed.md.

For each ride, each effect of :mod:`conceal` (studies/conceal.py) in turn, two pairs
of effects together, and a null are hidden in a copy of the log; the
differences of ``euc-sim ride CLEAN --compare COPY`` are computed with the
functions that command calls (``ride_drivetrain`` then ``pair_differences``;
the balance, controller and simulation steps do not feed the differences) and
read: is every hidden effect named and nothing else, is each sized within
±30 % (or its truth inside its interval), does the null name nothing.

Usage::

    python studies/concealed_rides.py --work /tmp/concealed [--rides aero_0 v9_0] [--cases null drag]

Each copy and its two rides' drivetrain fits stay in ``--work`` (pickled, read
again when there); the differences are recomputed on every run.
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
from pathlib import Path

import conceal as cc

from euc_sim.rides.compare.resolution import Z95, predicted_gain
from euc_sim.rides.grids.power import RHO_AIR

#: The shared rides beside the repository (``--data`` elsewhere).
DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "euc_core"
#: label -> (ride, spec) under DATA.
RIDES = {
    "v9_0": ("trips/inmotion/v9/0/0.csv", "v9"), "v9_1": ("trips/inmotion/v9/1/1.csv", "v9"),
    "blitz_1": ("trips/begode/blitz/1/1.csv", "blitz"), "lynx_0": ("trips/leaperkim/lynx/0/0.csv", "lynx"),
    "aero_0": ("trips/nosfet/aero/0/0.csv", "aero"), "apex_0": ("trips/nosfet/apex/0/0.csv", "apex"),
}
#: case -> ((effect, size, the difference expected, in the differences' units), ...).
CASES = {
    "null": (),
    "mass15": (("total_mass", 15.0, 15.0),),
    "mass30": (("total_mass", 30.0, 30.0),),
    "drag": (("aerodynamic_drag", 0.25, 0.5 * RHO_AIR * 0.25),),
    "rolling": (("rolling_resistance", 0.01, 0.01),),
    "battery": (("internal_resistance", 0.08, 0.08),),
    "tyre": (("speed_scale", 1.05, 1.0 / 1.05 - 1.0),),
    "delay": (("current_delay", 0.4, 0.4),),
    "drag+mass30": (("aerodynamic_drag", 0.25, 0.5 * RHO_AIR * 0.25), ("total_mass", 30.0, 30.0)),
    "battery+tyre": (("internal_resistance", 0.08, 0.08), ("speed_scale", 1.05, 1.0 / 1.05 - 1.0)),
}


def _rider_total(data: Path, ride: str, spec: str) -> float:
    """Rider weight from meta.csv plus the spec's net weight (25 kg where none), kg: the rolling injection's m."""
    import pandas as pd

    from euc_sim.rides.source.spec import wheel_spec

    meta = pd.read_csv((data / ride).parent / "meta.csv").iloc[0]
    net = wheel_spec(data / "specs" / f"{spec}.csv").wheel_mass
    return float(meta["rider_weight"]) + (net if net is not None else 25.0)


def _concealed(data: Path, label: str, case: str, work: Path) -> Path:
    ride, spec = RIDES[label]
    out = work / f"{label}_{case}.csv"
    if out.exists():
        return out
    raw = cc.read_raw(data / ride)
    for effect, size, _ in CASES[case]:
        kw = {"total_mass": _rider_total(data, ride, spec)} if effect == "rolling_resistance" else {}
        raw = cc.conceal(raw, effect, size, **kw)
    return cc.write_raw(raw, out)


def _run(data: Path, label: str, case: str, work: Path) -> dict:
    """The ``differences`` of CLEAN against the copy (the two rides' drivetrain fits cached)."""
    from euc_sim.rides.compare.differences_report import pair_differences
    from euc_sim.report.ride.contract import differences_json
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.drive.drivetrain_report import ride_drivetrain

    cache = work / f"{label}_{case}.pkl"
    if cache.exists():
        log, other, physics = pickle.loads(cache.read_bytes())
    else:
        log, other = read_log(data / RIDES[label][0]), read_log(_concealed(data, label, case, work))
        physics = ride_drivetrain(log, other)
        cache.write_bytes(pickle.dumps((log, other, physics)))
    return differences_json(pair_differences(physics, log, other))


def score(rep: dict, case: str) -> dict:
    """Every hidden effect named and nothing else? each sized? for one run."""
    diffs = {d["name"]: d for d in rep["differences"]}
    named = sorted(n for n, d in diffs.items() if d.get("named"))
    row = {"case": case, "named": named, "sizes": {},
           "resolvable": {n: d.get("resolvable") for n, d in diffs.items() if d.get("resolvable") is not None}}
    sized = []
    for effect, _, truth in CASES[case]:
        d = diffs.get(effect, {})
        est, ci = d.get("estimate"), d.get("ci95")
        ok = est is not None and bool(abs(est - truth) <= 0.3 * abs(truth)
                                  or (ci is not None and ci[0] <= truth <= ci[1]))
        row["sizes"][effect] = {"estimate": est, "ci95": ci, "sized": ok,
                                "named": effect in named, "heldout_gain": d.get("heldout_gain"),
                                "resolvable": d.get("resolvable"), "resolution": d.get("resolution")}
        sized.append(ok)
    row["ok"] = named == sorted(e for e, _, _ in CASES[case]) and all(sized)
    return row


def _cell(row: dict) -> str:
    named = ", ".join(row["named"]) or "nothing"
    sizes = [f"{v['estimate']:.3g} [{v['ci95'][0]:.3g}, {v['ci95'][1]:.3g}]"
             if v["estimate"] is not None and v["ci95"] else str(v["estimate"])
             for v in row["sizes"].values()]
    return f"{'yes' if row['ok'] else 'no'} | {named} | {'; '.join(sizes)}"


def table(rows: list) -> str:
    """Markdown table of :func:`score` rows."""
    out = ["| ride | case | truth | passes | named | estimate [95 % interval] |",
           "|---|---|---|---|---|---|"]
    for r in rows:
        truth = "; ".join(f"{t:.3g}" for _, _, t in CASES[r["case"]]) or "—"
        out.append(f"| {r['ride']} | {r['case']} | {truth} | {_cell(r)} |")
    return "\n".join(out)


def counts(rows: list) -> dict:
    """Passes per case over the rows given: ``{case: "k/n"}``."""
    out = {}
    for case in CASES:
        rs = [r for r in rows if r["case"] == case]
        if rs:
            out[case] = f"{sum(r['ok'] for r in rs)}/{len(rs)}"
    return out


def resolution_rows(rows: list) -> list:
    """Per ride × hidden effect: the truth, the smallest nameable difference (on the ride's null pair,
    before anything is hidden, and on the concealed pair itself), predicted named, named."""
    null = {r["ride"]: r.get("resolvable", {}) for r in rows if r["case"] == "null"}
    out = []
    for r in rows:
        for effect, _, truth in CASES[r["case"]]:
            v = r["sizes"][effect]
            res, pre = v.get("resolvable"), null.get(r["ride"], {}).get(effect)
            predicted = None if res is None else bool(abs(truth) > res)
            det = v.get("resolution") or {}
            gain = (None if det.get("gate") is None else
                    predicted_gain(truth, det["residual_rms"], det["signature_rms"],
                                   det["interval_halfwidth"] / Z95, 5))
            out.append({"ride": r["ride"], "case": r["case"], "effect": effect, "truth": truth,
                        "resolvable_null": pre, "resolvable": res, "predicted": predicted,
                        "predicted_null": None if pre is None else bool(abs(truth) > pre),
                        "predicted_estimate": (None if res is None or v["estimate"] is None
                                               else bool(abs(v["estimate"]) > res)),
                        "named": v["named"], "gate": det.get("gate"), "halfwidth": det.get("interval_halfwidth"),
                        "estimate": v["estimate"], "gain_predicted": gain, "gain": v.get("heldout_gain"),
                        "gain_se": det.get("gain_se")})
    return out


def resolution_table(rows: list) -> str:
    """Markdown table of :func:`resolution_rows` and the agreements counted."""
    yn = {True: "yes", False: "no", None: "–"}
    g = (lambda x: "–" if x is None else f"{x:.3g}")
    pct = (lambda x: "–" if x is None else f"{100 * x:+.1f} %")
    out = ["| ride | case | effect | truth | estimate | resolvable (null pair) | resolvable (this pair) "
           "[half-width; gate] | held-out gain at the truth, predicted / measured ± fold se | predicted | named | "
           "agree |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    rs = resolution_rows(rows)
    for x in rs:
        agree = None if x["predicted"] is None else x["predicted"] == x["named"]
        out.append(f"| {x['ride']} | {x['case']} | {x['effect']} | {x['truth']:.3g} | {g(x['estimate'])} | "
                   f"{g(x['resolvable_null'])} | {g(x['resolvable'])} [{g(x['halfwidth'])}; {g(x['gate'])}] | "
                   f"{pct(x['gain_predicted'])} / {pct(x['gain'])}"
                   + ("" if x["gain_se"] is None else f" ± {100 * x['gain_se']:.1f}") + f" | {yn[x['predicted']]} | "
                   f"{yn[x['named']]} | {yn[agree]} |")
    for key, what in (("predicted", "this pair"), ("predicted_null", "the null pair"),
                      ("predicted_estimate", "this pair, its estimate (not the truth) against it")):
        ok = [x for x in rs if x[key] is not None]
        n_ok = sum(x[key] == x["named"] for x in ok)
        miss = [f"{x['ride']} {x['case']} {x['effect']}" for x in ok if x[key] != x["named"]]
        out.append(f"\nResolution from {what}: predicted = named in {n_ok} of {len(ok)}"
                   + (f" (not: {'; '.join(miss)})" if miss else ""))
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", default=str(DATA), help="the shared euc_core folder")
    p.add_argument("--work", required=True, help="folder for the concealed copies and the runs' JSON")
    p.add_argument("--rides", nargs="+", default=list(RIDES), choices=list(RIDES))
    p.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    args = p.parse_args(argv)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for label in args.rides:
        for case in args.cases:
            row = {"ride": label, **score(_run(Path(args.data), label, case, work), case)}
            rows.append(row)
            print(json.dumps(row), flush=True)
    (work / "scores.json").write_text(json.dumps(rows, indent=1))
    print(table(rows))
    print(json.dumps(counts(rows)))
    print(resolution_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
