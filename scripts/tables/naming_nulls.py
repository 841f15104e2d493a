"""How often does ``ride LOG --compare OTHER`` name a difference between two rides that do not differ?

Real null pairs of the shared euc_core rides (``../shared/data/euc_core/trips/*/*/N/N.csv``):

* each ride's two halves, the first as LOG and the second as OTHER (the log cut in
  two at its middle time, passed as sliced logs; same wheel, rider, tyre and day);
  with ``--quarters`` also its first quarter against its second and its third
  against its fourth;
* consecutive rides of one wheel whose ``meta.csv`` records the same tyre pressure,
  temperature and wind.

For each pair the differences are computed with the functions
``euc-sim ride LOG --compare OTHER`` calls (``ride_drivetrain`` then
``pair_differences``; the two rides' drivetrain fits are pickled in ``--work`` and
read again when there, the differences recomputed on every run).  A pair names
falsely when it names anything; the rate over the pairs is given with its
Clopper–Pearson 95 % interval.  Written up in docs/concealed.md ("False names on
real null pairs").

Usage (from the repository root)::

    nice python scripts/tables/naming_nulls.py --work /tmp/naming_nulls [--quarters] [--channels] [--only blitz/1 v9/0]
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import pickle
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "euc_core"
#: meta.csv columns that must agree for two rides to be a null pair.
SAME = ("tire_pressure", "temperature", "wind")


def _meta(csv_path: Path) -> dict:
    with open(csv_path.parent / "meta.csv", newline="") as fh:
        return next(csv.DictReader(fh))


def _part(log, i: int, n: int):
    """The ``i``-th of ``n`` equal parts of a parsed log (by time), its clock restarted at zero."""
    import pandas as pd

    d = log.data
    end = float(d["t"].iloc[-1])
    part = d[(d["t"] >= i * end / n) & ((d["t"] < (i + 1) * end / n) if i < n - 1 else True)]
    t0 = float(part["t"].iloc[0])
    part = part.assign(t=part["t"] - t0).reset_index(drop=True)
    stem = Path(log.path)
    name = stem.with_name(f"{stem.stem}_part{i + 1}of{n}{stem.suffix}")
    return dataclasses.replace(log, path=str(name), data=part, start=log.start + pd.Timedelta(seconds=t0))


def pairs(data: Path, only=None, quarters: bool = False) -> list[tuple[str, Path, Path | None]]:
    """``(label, LOG, OTHER)``: OTHER ``None`` for a ride's halves, ``(i, j, n)`` for its parts i and j of n."""
    rides = sorted(data.glob("trips/*/*/*/*.csv"))
    rides = [r for r in rides if r.name != "meta.csv" and r.stem == r.parent.name]
    if only:
        rides = [r for r in rides if f"{r.parts[-3]}/{r.parts[-2]}" in only]
    out = [(f"{r.parts[-3]}/{r.parts[-2]} halves", r, (0, 1, 2)) for r in rides]
    if quarters:
        out += [(f"{r.parts[-3]}/{r.parts[-2]} quarters {i + 1}-{i + 2}", r, (i, i + 1, 4))
                for r in rides for i in (0, 2)]
    by_wheel: dict = {}
    for r in rides:
        by_wheel.setdefault(r.parts[-3], []).append(r)
    for wheel, rs in by_wheel.items():
        rs = sorted(rs, key=lambda r: int(r.parent.name))
        for a, b in zip(rs, rs[1:]):
            ma, mb = _meta(a), _meta(b)
            if all(ma[k].strip() == mb[k].strip() for k in SAME):
                out.append((f"{wheel}/{a.parent.name} → {b.parent.name}", a, b))
    return out


def run(label: str, a: Path, b, work: Path, channels=()) -> dict:
    """The named differences of one null pair (drivetrain fits cached in ``work``; ``channels``
    stacked beside battery power, :mod:`euc_sim.rides.compare.channels`)."""
    from euc_sim.rides.compare.differences_report import pair_differences
    from euc_sim.report.ride.contract import differences_json
    from euc_sim.rides.drive.drivetrain_report import ride_drivetrain
    from euc_sim.rides.source.logs import read_log

    cache = work / (label.replace("/", "_").replace(" → ", "-").replace(" ", "_") + ".pkl")
    if cache.exists():
        log, other, physics = pickle.loads(cache.read_bytes())
    else:
        log = read_log(a, emit_warnings=False)
        log, other = (_part(log, b[0], b[2]), _part(log, b[1], b[2])) if isinstance(b, tuple) \
            else (log, read_log(b, emit_warnings=False))
        physics = ride_drivetrain(log, other)
        cache.write_bytes(pickle.dumps((log, other, physics)))
    rep = differences_json(pair_differences(physics, log, other, channels=channels))
    diffs = rep["differences"]
    return {"pair": label, "named": sorted(d["name"] for d in diffs if d.get("named")),
            "sizes": {d["name"]: [d["estimate"], d["ci95"]] for d in diffs if d.get("named")},
            "p": {d["name"]: d.get("p_value") for d in diffs if d.get("p_value") is not None},
            "q": {d["name"]: d.get("q_value") for d in diffs if d.get("q_value") is not None},
            "alias_sets": {d["name"]: d["alias_set"] for d in diffs if d.get("alias_set")}}


def table(rows: list) -> str:
    """Markdown: one line per pair, then the false-name rate and its Clopper–Pearson interval."""
    from scipy.stats import binomtest

    g = (lambda x: "–" if x is None else f"{x:.2g}")
    out = ["| pair | named [95 % interval] | smallest p (its candidate) | smallest q |", "|---|---|---|---|"]
    for r in rows:
        best = min(r["p"].items(), key=lambda kv: kv[1], default=(None, None))
        q = min(r["q"].values(), default=None)
        named = [f"{n} {e:.3g} [{ci[0]:.3g}, {ci[1]:.3g}]" for n, (e, ci) in r.get("sizes", {}).items()]
        out.append(f"| {r['pair']} | {'; '.join(named) or ', '.join(r['named']) or 'nothing'} | "
                   f"{g(best[1])}{'' if best[0] is None else f' ({best[0]})'} | {g(q)} |")

    def rate(what: str, k: int, n: int) -> str:
        ci = binomtest(k, n).proportion_ci(0.95, method="exact")
        return (f"\n{what}: {k} of {n} ({100 * k / n:.1f} %; Clopper–Pearson 95 % "
                f"{100 * ci.low:.1f}–{100 * ci.high:.1f} %).")

    n = len(rows)
    if n:
        out.append(rate("Pairs naming anything", sum(bool(r["named"]) for r in rows), n))
        road = [r for r in rows if set(r["named"]) - {"internal_resistance"}]
        out.append(rate("Pairs naming anything but the battery resistance (which changes along one ride "
                        "with its charge and pack temperature)", len(road), n))
        tests = sum(len([c for c in r["p"] if c != "drivetrain_idle_loss"]) for r in rows)
        if tests:
            out.append(rate("Candidates named, over every candidate tested", sum(len(r["named"]) for r in rows),
                            tests))
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", default=str(DATA), help="the shared euc_core folder")
    p.add_argument("--work", required=True, help="folder for the pickled drivetrain fits and rows.json")
    p.add_argument("--only", nargs="+", help="wheel/N rides to use (e.g. blitz/1)")
    p.add_argument("--quarters", action="store_true", help="also each ride's quarters 1-2 and 3-4")
    p.add_argument("--channels", action="store_true",
                   help="stack the phase current and voltage sag beside battery power (channels.CHANNELS)")
    args = p.parse_args(argv)
    from euc_sim.rides.compare.channels import CHANNELS
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    from euc_sim.rides.grids.power import RideDataError

    for label, a, b in pairs(Path(args.data), args.only, args.quarters):
        try:
            rows.append(run(label, a, b, work, CHANNELS if args.channels else ()))
        except RideDataError as e:         # a part with too little riding: no pair, said
            print(f"{label}: skipped ({e})", file=sys.stderr, flush=True)
            continue
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    (work / "rows.json").write_text(json.dumps(rows, indent=1))
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
