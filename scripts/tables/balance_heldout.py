"""The balance model's held-out errors on every shared ride (docs/ride_model.md).

For every ride of ``../shared/data/euc_core/`` (with its wheel's spec) and every
WheelLog log of ``../shared/data/wheellog/``: the ride's halves (fit on the first,
test on the second), and the WheelLog pair both ways.  Each comparison is run as
``euc-sim ride`` runs it: the total mass from the log's energy balance
(``ride_drivetrain``), handed to the balance fit (``with_found_values``), then
``ride_analysis``.  Tabulated: held-out RMS error of the inertia-only model, of
the selected (accepted) model and of the fit with every candidate, the ratio
selected / inertia-only, and how far the fit with every candidate beats the
selected one out of sample (the rule: by no more than 5 %).

Usage::

    nice python scripts/tables/balance_heldout.py [--only SUBSTR] [--pairs v9] [--json OUT.json]

The balance fits use no bootstrap (the selection and the acceptance read point
estimates only); the mass fit uses ``--n-boot`` replicates (default 10).
"""

from __future__ import annotations

import argparse
import csv
import sys
import warnings
from pathlib import Path

SHARED = Path(__file__).resolve().parents[3] / "shared" / "data"
#: The rule: the selected model is not beaten out of sample by more than this fraction.
RULE = 0.05


def cases(root: Path = SHARED, pair_wheels: tuple = ()) -> list[dict]:
    """Every comparison: (label, log, compare or None, spec path or None).

    ``pair_wheels``: wheels (``meta.csv``'s ``wheel``, e.g. ``v9``) whose rides are
    also compared pairwise, every ordered pair (fit on one, test on the other).
    """
    out, by_wheel = [], {}
    for meta in sorted((root / "euc_core").glob("trips/*/*/*/meta.csv")):
        with open(meta, newline="") as fh:
            row = next(csv.DictReader(fh))
        folder = meta.parent
        spec = root / "euc_core" / "specs" / f"{row['wheel']}.csv"
        out.append({"label": f"{row['wheel']}/{folder.name} halves",
                    "log": folder / f"{folder.name}.csv", "compare": None,
                    "spec": spec if spec.exists() else None})
        by_wheel.setdefault(row["wheel"], []).append(out[-1])
    for wheel in pair_wheels:
        for a in by_wheel.get(wheel, []):
            for b in by_wheel[wheel]:
                if a is not b:
                    out.append({"label": f"{wheel}/{a['log'].stem} -> {b['log'].stem}",
                                "log": a["log"], "compare": b["log"], "spec": a["spec"]})
    wl = root / "wheellog"
    logs = sorted(wl.glob("*.csv"))
    for p in logs:
        out.append({"label": f"wheellog/{p.stem} halves", "log": p, "compare": None, "spec": None})
    pair = [wl / "2020_05_16_08_02_06.csv", wl / "2020_05_28_07_52_00.csv"]
    if all(p.exists() for p in pair):
        for a, b in (pair, pair[::-1]):
            out.append({"label": f"wheellog {a.stem[5:10]} -> {b.stem[5:10]}", "log": a,
                        "compare": b, "spec": None})
    return out


def one(case: dict, n_boot: int, seed: int) -> dict:
    """Run one comparison as ``euc-sim ride`` fits it; the row of the table."""
    from euc_sim.rides.balance.crossride import admissible
    from euc_sim.rides.balance.design import NOMINAL
    from euc_sim.rides.pipeline import balance_on_mass
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import read_spec

    spec = read_spec(case["spec"]) if case["spec"] else None
    log = read_log(case["log"], emit_warnings=False)
    compare = None if case["compare"] is None else read_log(case["compare"], emit_warnings=False)
    fitted = balance_on_mass(log, compare, spec, n_boot=0, n_boot_mass=n_boot, seed=seed)
    assumptions, cr = fitted.assumptions, fitted.analysis.cross
    beaten = cr.heldout_augmented / cr.heldout_full - 1.0
    return {"label": case["label"], "total_mass": assumptions.total_mass,
            "inertia_only": cr.heldout_nominal, "selected": cr.heldout_augmented,
            "every_candidate": cr.heldout_full, "ratio": cr.ratio, "beaten_by": beaten,
            "rule_met": bool(beaten <= RULE), "accepted": list(cr.accepted),
            "every_candidate_inadmissible": sorted(set(cr.full.names) - set(NOMINAL) - set(
                admissible(cr.full, cr.full.names, cr.fit_design.idle_cap))),
            "selected_terms": list(cr.selected),
            "all_estimates": {k: round(v, 4) for k, v in cr.full.estimate.items()},
            "augmented_estimates": {k: round(v, 4) for k, v in cr.augmented.estimate.items()},
            "fit_rows": len(cr.fit_design.P)}


def table(rows: list[dict]) -> str:
    """Markdown table of the rows."""
    out = ["| comparison | mass kg | inertia-only W | selected W | every candidate W | ratio | "
           "beaten by | accepted | kept, not accepted | every candidate holds, implausible |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "error" in r:
            out.append(f"| {r['label']} | error: {r['error']} ||||||||")
            continue
        off = [c for c in r["selected_terms"] if c not in r["accepted"]]
        out.append(f"| {r['label']} | {r['total_mass']:.0f} | {r['inertia_only']:.1f} | "
                   f"{r['selected']:.1f} | {r['every_candidate']:.1f} | {r['ratio']:.2f} | "
                   f"{100 * r['beaten_by']:+.1f} %{'' if r['rule_met'] else ' **fails**'} | "
                   f"{', '.join(r['accepted']) or '—'} | {', '.join(off) or '—'} | "
                   f"{', '.join(r['every_candidate_inadmissible']) or '—'} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default=None, help="run only comparisons whose label holds this")
    ap.add_argument("--pairs", default="", help="comma-separated wheels (e.g. v9) whose rides "
                    "are also compared pairwise")
    ap.add_argument("--n-boot", type=int, default=10, help="mass-fit bootstrap replicates")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None, help="write the rows as JSON here")
    a = ap.parse_args(argv)
    if not SHARED.is_dir():
        print(f"{SHARED}: shared ride data not found", file=sys.stderr)
        return 2
    rows = []
    for case in cases(pair_wheels=tuple(w for w in a.pairs.split(",") if w)):
        if a.only and a.only not in case["label"]:
            continue
        print(f"... {case['label']}", file=sys.stderr, flush=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                rows.append(one(case, a.n_boot, a.seed))
            except ValueError as exc:          # a ride the balance cannot use: say which, go on
                rows.append({"label": case["label"], "error": str(exc).splitlines()[0][:120]})
    print(table(rows))
    met = [r for r in rows if r.get("rule_met")]
    print(f"\nrule (selected not beaten by {100 * RULE:.0f} % by every candidate): "
          f"{len(met)}/{sum('error' not in r for r in rows)} comparisons")
    if a.json:
        from euc_sim.io import write_json

        write_json(a.json, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
