"""Known effects hidden in the shared EUC World rides: does ``ride CLEAN --compare CONCEALED`` name them? Written up in docs/concealed.md.

For each ride, each effect of :mod:`euc_sim.rides.conceal` in turn (and a null)
is hidden in a copy of the log; ``euc-sim ride CLEAN --compare COPY --no-simulate``
is run (nice'd) and its ``differences`` read: is the hidden effect named alone,
is it sized within ±30 % (or its truth inside its interval), does the null name
nothing.  Two rules are tabulated: ``named`` (the difference's interval from the
two rides' intervals, independent rides) and ``named_given_log_model`` (OTHER's
residual under LOG's fitted model).

Usage::

    python studies/concealed_rides.py --work /tmp/concealed [--rides aero v9_0] [--cases null drag]

Each run's JSON stays in ``--work`` (a run already there is read, not redone).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from euc_sim.rides import conceal as cc
from euc_sim.rides.power import RHO_AIR

#: The shared rides beside the repository (``--data`` elsewhere).
DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "euc_core"
#: label -> (ride, spec) under DATA.
RIDES = {
    "v9_0": ("trips/inmotion/v9/0/0.csv", "v9"), "v9_1": ("trips/inmotion/v9/1/1.csv", "v9"),
    "blitz_1": ("trips/begode/blitz/1/1.csv", "blitz"), "lynx_0": ("trips/leaperkim/lynx/0/0.csv", "lynx"),
    "aero_0": ("trips/nosfet/aero/0/0.csv", "aero"), "apex_0": ("trips/nosfet/apex/0/0.csv", "apex"),
}
#: case -> (effect, size, the difference expected, in the differences' units).
CASES = {
    "null": ("null", 0.0, None),
    "mass15": ("total_mass", 15.0, 15.0),
    "mass30": ("total_mass", 30.0, 30.0),
    "drag": ("aerodynamic_drag", 0.25, 0.5 * RHO_AIR * 0.25),
    "rolling": ("rolling_resistance", 0.01, 0.01),
    "battery": ("internal_resistance", 0.08, 0.08),
    "tyre": ("speed_scale", 1.05, 1.0 / 1.05 - 1.0),
    "delay": ("current_delay", 0.4, 0.4),
}


def _rider_total(data: Path, ride: str, spec: str) -> float:
    """Rider weight from meta.csv plus the spec's net weight (25 kg where none), kg: the rolling injection's m."""
    import pandas as pd

    from euc_sim.rides.spec import wheel_spec

    meta = pd.read_csv((data / ride).parent / "meta.csv").iloc[0]
    net = wheel_spec(data / "specs" / f"{spec}.csv").wheel_mass
    return float(meta["rider_weight"]) + (net if net is not None else 25.0)


def _concealed(data: Path, label: str, case: str, work: Path) -> Path:
    ride, spec = RIDES[label]
    out = work / f"{label}_{case}.csv"
    if out.exists():
        return out
    effect, size, _ = CASES[case]
    raw = cc.read_raw(data / ride)
    kw = {"total_mass": _rider_total(data, ride, spec)} if effect == "rolling_resistance" else {}
    return cc.write_raw(cc.conceal(raw, effect, size, **kw), out)


def _run(data: Path, label: str, case: str, work: Path) -> dict:
    js = work / f"{label}_{case}.json"
    if not js.exists():
        cmd = ["nice", sys.executable, "-m", "euc_sim.cli", "ride", str(data / RIDES[label][0]),
               "--compare", str(_concealed(data, label, case, work)), "--no-simulate", "--quiet",
               "--json", str(js)]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return json.loads(js.read_text())


def score(rep: dict, case: str) -> dict:
    """Named alone? sized? under both rules, for one run."""
    effect, _, truth = CASES[case]
    diffs = {d["name"]: d for d in rep["differences"]}
    row = {"case": case}
    for rule, key in (("independent", "named"), ("given_log_model", "named_given_log_model")):
        named = sorted(n for n, d in diffs.items() if d.get(key))
        row[f"{rule}_named"] = named
        if truth is None:
            row[f"{rule}_ok"] = not named
            continue
        d = diffs.get(effect, {})
        est, ci = ((d.get("estimate"), d.get("ci95")) if rule == "independent" else
                   ((d.get("given_log_model") or {}).get("estimate"),
                    (d.get("given_log_model") or {}).get("ci95")))
        sized = est is not None and (abs(est - truth) <= 0.3 * abs(truth)
                                     or (ci is not None and ci[0] <= truth <= ci[1]))
        row[f"{rule}_estimate"], row[f"{rule}_ci95"] = est, ci
        row[f"{rule}_ok"] = named == [effect] and sized
    return row


def _cell(row: dict, rule: str) -> str:
    named = ", ".join(row[f"{rule}_named"]) or "nothing"
    est = row.get(f"{rule}_estimate")
    size = "" if est is None else f" {est:.3g}"
    ci = row.get(f"{rule}_ci95")
    size += "" if not ci else f" [{ci[0]:.3g}, {ci[1]:.3g}]"
    return f"{'yes' if row[f'{rule}_ok'] else 'no'}: {named};{size}"


def table(rows: list) -> str:
    """Markdown table of :func:`score` rows."""
    out = ["| ride | case | truth | independent rule | given LOG's model |", "|---|---|---|---|---|"]
    for r in rows:
        truth = CASES[r["case"]][2]
        out.append(f"| {r['ride']} | {r['case']} | {'—' if truth is None else f'{truth:.3g}'} | "
                   f"{_cell(r, 'independent')} | {_cell(r, 'given_log_model')} |")
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
