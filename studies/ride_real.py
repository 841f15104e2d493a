"""Fitted the longitudinal balance on one real ride and predicted another, both ways: the first check of what euc-sim ride now does (docs/real_rides.md).

Fit the longitudinal balance on one real ride and predict another, both ways.

Usage (from the repository root)::

    python studies/ride_real.py [OUT_DIR] [--domain power|torque]

Reads the two WheelLog rides in ``../shared/data/wheellog/`` and writes, per
direction, ``OUT_DIR/<fit>_to_<test>/ride_balance.csv`` and ``report.json`` (CONTRACT's ``euc-sim ride`` JSON form), then prints a summary.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from euc_sim.io import write_json
from euc_sim.rides.balance.analysis import ride_analysis
from euc_sim.report.ride.contract import balance_json
from euc_sim.rides.balance.parameters import effect_estimates, parameter_list
from euc_sim.report.ride.fit_figures import write_balance
from euc_sim.rides.source.logs import read_log

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "wheellog"
RIDES = ["2020_05_16_08_02_06.csv", "2020_05_28_07_52_00.csv"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default="runs/ride_real")
    ap.add_argument("--domain", choices=["power", "torque"], default="power")
    ap.add_argument("--n-boot", type=int, default=200)
    args = ap.parse_args(argv)
    if not SHARED.is_dir():
        print(f"ride_real: {SHARED} not found", file=sys.stderr)
        return 2
    out = Path(args.out)
    for fit, test in [(RIDES[0], RIDES[1]), (RIDES[1], RIDES[0])]:
        d = out / f"{Path(fit).stem}_to_{Path(test).stem}_{args.domain}"
        an = ride_analysis(read_log(SHARED / fit), read_log(SHARED / test), domain=args.domain,
                           n_boot=args.n_boot)
        effects = effect_estimates(an.cross, parameter_list(an.cross, None, {}))
        rep = dict(balance_json(an, effects), table=write_balance(an, d).name)
        write_json(d / "report.json", rep)
        print(f"fit {fit} -> test {test} ({args.domain}): held-out RMS inertia-only "
              f"{rep['heldout_error_nominal']:.1f} {rep['error_unit']}, augmented "
              f"{rep['heldout_error_augmented']:.1f}, ratio {rep['ratio']:.3f}; all candidates "
              f"{rep['heldout_error_all_candidates']:.1f}")
        for name, e in rep["nominal_parameters"].items():
            print(f"    {name:22s} {e['estimate']:9.4g} {e['unit']:5s} 95% [{e['ci95'][0]:.4g}, "
                  f"{e['ci95'][1]:.4g}]  plausible={e['plausible']}")
        for e in rep["effects"]:
            print(f"  + {e['name']:22s} {e['estimate']:9.4g} {e['unit']:5s} 95% [{e['ci95'][0]:.4g}, "
                  f"{e['ci95'][1]:.4g}]  plausible={e['plausible']}  aliases={e['aliases']}")
        for name, e in rep["all_estimates"].items():
            print(f"    full fit {name:22s} {e['estimate']:9.4g} {e['unit']:5s} "
                  f"95% [{e['ci95'][0]:.4g}, {e['ci95'][1]:.4g}]  plausible={e['plausible']}")
        print(f"    figure {rep['figure']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
