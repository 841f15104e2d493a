#!/usr/bin/env python
"""How the gap policy's bridge moves a ride's balance selection (docs/ride_model.md, the 5 % rule).

    nice python studies/balance_gap_split.py [LOG] [--spec SPEC] [--compare OTHER ...]

Default LOG: ``../shared/data/euc_core/trips/inmotion/v9/1/1.csv`` with the V9
spec.  The total mass is the log's energy balance (10 replicates, as
``scripts/tables/balance_heldout.py``).  For the bridge at 1.0 s and at 2.5 s
(``GapPolicy.bridge``) it prints:

1. the halves as ``euc-sim ride`` fits them (``--compare``: that ride instead):
   accepted terms, held-out inertia-only / selected / every-candidate error;
2. where the halves split, the fit half's rows, and the rolling + drag pair's
   C_rr and k (95 % block-bootstrap interval of C_rr) on the fit half and on the
   whole ride; on the whole ride at 2.5 s also on the rows the 1.0 s design has,
   and on those it leaves out;
3. the pair's C_rr fitted on the ride up to a cut, for cuts every 25 s around
   the split (how far the acceptance depends on where the fit half ends).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

from euc_sim.rides.balance.analysis import ride_analysis, split_time
from euc_sim.rides.balance.design import NOMINAL, balance_design
from euc_sim.rides.balance.fit import fit_balance
from euc_sim.rides.grids.signals import RideAssumptions, ride_signals, with_found_values
from euc_sim.rides.drive.drivetrain_report import ride_drivetrain
from euc_sim.rides.source.logs import read_log
from euc_sim.rides.source.spec import read_spec

CORE = Path(__file__).resolve().parents[2] / "shared" / "data" / "euc_core"
PAIR = list(NOMINAL) + ["rolling_resistance", "aerodynamic_drag"]
BRIDGES = (1.0, 2.5)


def pair_line(design, label: str, n_boot: int, seed: int) -> str:
    """The rolling + drag pair fitted on ``design``: C_rr (with its interval) and k."""
    f = fit_balance(design, PAIR, n_boot=n_boot, seed=seed)
    c, k = f.estimate["rolling_resistance"], f.estimate["aerodynamic_drag"]
    ci = (f", 95 % [{f.ci95['rolling_resistance'][0]:.4f}, {f.ci95['rolling_resistance'][1]:.4f}]"
          if n_boot else "")
    return f"  {label}: {len(design.P)} rows, C_rr {c:.4f}{ci}, k {k:.4f} kg/m"


def halves_line(log, compare, assumptions, bridge: float) -> str:
    """The comparison as ``euc-sim ride`` fits it (no bootstrap) at this bridge."""
    cr = ride_analysis(log, compare, assumptions=assumptions, max_gap=bridge, n_boot=0).cross
    beaten = cr.heldout_augmented / cr.heldout_full - 1.0
    return (f"bridge {bridge} s: accepted {', '.join(cr.accepted) or 'nothing'}; held out "
            f"{cr.heldout_nominal:.1f} -> {cr.heldout_augmented:.1f} W, every candidate "
            f"{cr.heldout_full:.1f} W (beaten by {100 * beaten:+.1f} %)")


def designs(log, assumptions) -> dict:
    """The whole ride's balance design at each bridge."""
    return {b: balance_design(ride_signals(log, assumptions, max_gap=b), "power")
            for b in BRIDGES}


def split_report(d: dict, n_boot: int, seed: int) -> list[str]:
    """Step 2: the split, the pair on the fit half and the whole ride, the rows 1.0 s drops."""
    out = []
    for b, design in d.items():
        t_mid = split_time(design.t)
        out.append(f"  bridge {b} s: the halves split at {t_mid:.0f} s")
        out.append(pair_line(design.rows(design.t < t_mid), "fit half", n_boot, seed))
        out.append(pair_line(design, "whole ride", n_boot, seed))
    key = lambda t: np.round(np.asarray(t) * 10.0).astype(np.int64)  # noqa: E731 (10 Hz rows)
    lo, hi = d[min(BRIDGES)], d[max(BRIDGES)]
    shared = np.isin(key(hi.t), key(lo.t))
    out.append(pair_line(hi.rows(shared), f"bridge {max(BRIDGES)} s, rows the "
                         f"{min(BRIDGES)} s design has", 0, seed))
    out.append(pair_line(hi.rows(~shared), f"bridge {max(BRIDGES)} s, rows the "
                         f"{min(BRIDGES)} s design leaves out", 0, seed))
    return out


def cut_scan(d: dict, step: float = 25.0, span: float = 150.0) -> list[str]:
    """Step 3: the pair's C_rr on the ride up to each cut around the halves' splits."""
    mids = [split_time(x.t) for x in d.values()]
    cuts = np.arange(step * np.floor((min(mids) - span) / step),
                     step * np.ceil((max(mids) + span) / step) + 1, step)
    out = ["  cut s:  " + " ".join(f"{c:6.0f}" for c in cuts)]
    for b, design in d.items():
        fits = [fit_balance(design.rows(design.t < c), PAIR, n_boot=0) for c in cuts]
        vals = [f.estimate["rolling_resistance"] for f in fits]
        out.append(f"  {b:.1f} s:  " + " ".join(f"{v:6.4f}" for v in vals))
    return out


def parse(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log", nargs="?", default=str(CORE / "trips/inmotion/v9/1/1.csv"))
    ap.add_argument("--spec", default=str(CORE / "specs/v9.csv"),
                    help="wheel spec CSV ('' for none)")
    ap.add_argument("--compare", nargs="*", default=[], help="rides to test on (else halves)")
    ap.add_argument("--n-boot", type=int, default=50, help="C_rr interval replicates")
    ap.add_argument("--seed", type=int, default=0)
    return ap.parse_args(argv)


def main(argv=None) -> int:
    a = parse(argv)
    for what, p in [("LOG", a.log), ("--spec", a.spec)] + [("--compare", c) for c in a.compare]:
        if p and not Path(p).is_file():
            print(f"{what}: {p} is not a file", file=sys.stderr)
            return 2
    warnings.simplefilter("ignore")
    try:
        spec = read_spec(a.spec) if a.spec else None
        log = read_log(a.log)
        others = [None] if not a.compare else [read_log(c) for c in a.compare]
    except (ValueError, OSError) as exc:          # a file that is no ride log or spec
        print(str(exc).splitlines()[0], file=sys.stderr)
        return 2
    mass = ride_drivetrain(log, None, spec, 10, a.seed)[0]["total_mass"]
    assumptions = with_found_values(RideAssumptions(), spec, mass)
    print(f"{Path(a.log).name}: total mass {assumptions.total_mass:.1f} kg (energy balance)")
    print("1. the comparison as `euc-sim ride` fits it")
    for name, cmp_ in zip(a.compare or ["halves"], others):
        print(f"  {name if cmp_ is None else '-> ' + name}")
        for b in BRIDGES:
            print("    " + halves_line(log, cmp_, assumptions, b), flush=True)
    d = designs(log, assumptions)
    print("2. the rolling + drag pair (C_rr's plausible top and bound: 0.05)")
    print("\n".join(split_report(d, a.n_boot, a.seed)), flush=True)
    print("3. the pair's C_rr fitted on the ride up to each cut")
    print("\n".join(cut_scan(d)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
