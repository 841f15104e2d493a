#!/usr/bin/env python
"""The README's identification table: synthetic analogues of the paper's recordings.

Each analogue is a closed-loop ride (``euc_sim.simulation.engine.simulate``, MuJoCo engine,
Table 3 with h = 0.6 m, 20 s) sampled like the paper's motion capture
(``euc_sim.simulation.mocap.motion_capture``: 120 Hz, 0.2 mm / 0.5° noise, seed 1), then
identified with both models exactly as ``euc-sim identify`` does.  Prints markdown
rows; ``--json`` writes the figures.

    python scripts/tables/identification_table.py
"""

from __future__ import annotations

import argparse
import sys

#: (label, maneuver, effects): the paper's four maneuvers of Fig. 8.  The figure-eight
#: analogue is a stop-and-go ride with the simulator's lateral_dynamics effect (a
#: slalom tilt of 0.2 rad with the yaw rate of a coordinated turn).
ANALOGUES = [
    ("deceleration", "deceleration", {}),
    ("acceleration", "acceleration", {}),
    ("constant speed", "constant_speed", {}),
    ("figure-eight analogue (lateral 0.2 rad)", "stop_and_go", {"lateral_dynamics": 0.2}),
]


def rows(seed: int = 1, duration: float = 20.0, smoothing=None):
    from euc_sim.identification.torques import MODELS
    from euc_sim.identification.h_fit import identify_h, residual_poly
    from euc_sim.simulation.mocap import motion_capture
    from euc_sim.model.parameters import TABLE3
    from euc_sim.identification.processing import Smoothing, kinematics
    from euc_sim.simulation.engine import simulate

    smoothing = smoothing or Smoothing()
    out = []
    for label, man, eff in ANALOGUES:
        run = simulate(man, duration, params=TABLE3, effects=eff or None)
        rec = motion_capture(run, TABLE3, noise="paper", seed=seed, effects=eff or None)
        kin = kinematics(rec, TABLE3, smoothing)
        for model in MODELS:
            f = identify_h([residual_poly(kin, TABLE3, model)], seed=seed)
            out.append({"maneuver": label, "model": model, "h": f.h, "h_ci95": f.h_ci95,
                        "rmse": f.rmse, "identifiable": f.identifiable,
                        "smoothing": smoothing.method})
    return out


def main(argv=None) -> int:
    from euc_sim.identification.processing import Smoothing

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--smoothing", choices=("consistent", "savgol"), default="consistent")
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    res = rows(args.seed, smoothing=Smoothing(method=args.smoothing))
    for r in res:
        flat = "" if r["identifiable"] else " (flat: not identifiable)"
        print(f"| {r['maneuver']} | {r['model'].replace('dof', '-DoF')} | {r['h']:.3f} "
              f"[{r['h_ci95'][0]:.3f}, {r['h_ci95'][1]:.3f}]{flat} | {r['rmse']:.2f} | "
              f"synthetic: `scripts/tables/identification_table.py --smoothing {r['smoothing']}` "
              f"(seed {args.seed}) |")
    if args.json:
        from euc_sim.io import write_json
        write_json(args.json, {"rows": res})
    return 0


if __name__ == "__main__":
    sys.exit(main())
