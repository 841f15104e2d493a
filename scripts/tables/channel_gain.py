"""What the log's other channels add to ``ride LOG --compare OTHER``: each road difference's resolution
(the smallest size named with 80 % power, ``resolvable``) with battery power alone and with every channel.

Reads pairs pickled by ``scripts/tables/naming_nulls.py`` (a ride's halves and
quarters) and ``studies/concealed_rides.py`` (a ride against its concealed copy):
``(LOG, OTHER, (ride JSON, LOG's fit, OTHER's fit))``.  For each pair the
differences are computed twice with the functions the CLI calls
(``pair_differences``): ``channels=()`` and the default
(:data:`euc_sim.rides.compare.channels.CHANNELS`, those both logs have).
Written up in docs/concealed.md ("Every channel of the log").

Usage (from the repository root)::

    nice python scripts/tables/channel_gain.py /tmp/naming_nulls/*_halves.pkl \
        /tmp/naming_conc/*_{null,mass30,drag,rolling}.pkl
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
from pathlib import Path

import numpy as np

#: The differences the channels can resolve better (the road's load).
ROAD = ("total_mass", "rolling_resistance", "aerodynamic_drag")
#: The concealed case's effect, by the pickle's suffix.
HIDDEN = {"mass30": "total_mass", "drag": "aerodynamic_drag", "rolling": "rolling_resistance"}


def run(path: Path) -> dict:
    """Each road difference's ``resolvable`` and ``named``, battery power alone and every channel."""
    from euc_sim.rides.compare.channels import CHANNELS
    from euc_sim.rides.compare.differences_report import pair_differences
    from euc_sim.report.ride.contract import differences_json
    from euc_sim.rides.source.channels import current_from_phase

    log, other, physics = pickle.loads(path.read_bytes())
    fit, test = physics.fit, physics.test
    has = {"sag": all(current_from_phase(x) for x in (log, other)),
           "phase_current": all("phase_current" in r.sig.extra for r in (fit, test)),
           "pwm": fit.drivetrain.pwm_coef is not None and all(
               "pwm" in r.sig.extra and not r.pwm_note for r in (fit, test))}
    used = [c for c in CHANNELS if has[c]]
    out = {"pair": path.stem, "channels": used}
    for key, ch in (("power", ()), ("all", CHANNELS)):
        diffs = {d["name"]: d for d in differences_json(pair_differences(physics, log, other, channels=ch))["differences"]}
        out[key] = {n: {"resolvable": diffs[n].get("resolvable"), "named": diffs[n].get("named"),
                        "estimate": diffs[n].get("estimate")} for n in ROAD if n in diffs}
    return out


def table(rows: list) -> str:
    """Markdown: per pair, each road difference's resolution alone → with every channel; then the medians."""
    g = (lambda x: "–" if x is None else f"{x:.3g}")
    out = ["| pair | channels | mass, kg | rolling | drag, kg/m | named (power → all) |", "|---|---|---|---|---|---|"]
    ratios = {n: [] for n in ROAD}
    for r in rows:
        cells = []
        for n in ROAD:
            a, b = r["power"].get(n, {}).get("resolvable"), r["all"].get(n, {}).get("resolvable")
            cells.append(f"{g(a)} → {g(b)}")
            if a and b and r["channels"]:
                ratios[n].append(b / a)
        named = lambda k: ", ".join(n for n in ROAD if r[k].get(n, {}).get("named")) or "nothing"  # noqa: E731
        out.append(f"| {r['pair']} | {', '.join(r['channels']) or 'none'} | {' | '.join(cells)} | "
                   f"{named('power')} → {named('all')} |")
    out.append("\nMedian resolution with every channel over battery power alone (pairs with another channel): "
               + "; ".join(f"{n} {np.median(v):.2f} ({sum(x < 1 for x in v)} of {len(v)} smaller)"
                           for n, v in ratios.items() if v) + ".")
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("pickles", nargs="*", help="pairs pickled by naming_nulls.py or concealed_rides.py")
    p.add_argument("--json", help="write the rows here too (with no pickles: read them from it)")
    args = p.parse_args(argv)
    if not args.pickles:
        if not args.json or not Path(args.json).exists():
            print("channel_gain.py: give pickles, or --json FILE of rows written before", file=sys.stderr)
            return 2
        print(table(json.loads(Path(args.json).read_text())))
        return 0
    rows = []
    for path in map(Path, args.pickles):
        rows.append(run(path))
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
