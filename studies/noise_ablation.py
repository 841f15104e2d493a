#!/usr/bin/env python
"""Showed that the error of h comes from the measurement noise (mostly the 0.5° on φ), not the rider's sway or the filter: docs/coverage.md.

Where does the error of h come from?  Ablations on simulated decelerations.

Each trajectory seed simulates the default deceleration (15 s, Table 3, h = 0.6 m)
with the rider's motor noise (``--rider-noise``, N·m; 0 for a rider who does not
sway); each is then recorded ``--draws`` times with fresh measurement noise and
identified (3-DoF and reduced model, the tool's consistent filter), for:

* the noise switched off, or on only one channel (γ, φ, x: the paper's 0.5° or 0.2 mm),
* the whole paper noise scaled by ½, 1 and 2 (errors in variables: a bias growing
  with the noise variance),
* the term filter's σ (0.2, 0.3, 0.5 s).

Prints the mean error of ĥ (against 0.6 m; the reduced model against its own h on the
noise-free recording), its sd and the standard error of the mean.

    python studies/noise_ablation.py [--trajectories 8] [--draws 20] [--rider-noise 3]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

ANGLE = math.radians(0.5)
POSITION = 0.2e-3


def main(argv=None) -> int:
    from euc_sim.identification.h_fit import identify_h, residual_poly
    from euc_sim.identification.processing import Smoothing, kinematics
    from euc_sim.model.parameters import TABLE3
    from euc_sim.simulation.engine import default_rider, simulate
    from euc_sim.simulation.mocap import motion_capture

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trajectories", type=int, default=8)
    ap.add_argument("--draws", type=int, default=20, help="measurement-noise draws per trajectory")
    ap.add_argument("--rider-noise", type=float, default=3.0, help="N·m")
    ap.add_argument("--first-seed", type=int, default=1)
    args = ap.parse_args(argv)

    def fit(rec, sigma=0.3):
        kin = kinematics(rec, TABLE3, Smoothing(term_sigma=sigma))
        return {m: identify_h([residual_poly(kin, TABLE3, m)], n_boot=0).h for m in ("3dof", "2dof")}

    rider = default_rider(TABLE3, noise_std=args.rider_noise)
    variants = {"paper": (POSITION, ANGLE, "all", 0.3), "none": (0, 0, "all", 0.3),
                "gamma only": (0, ANGLE, "gamma", 0.3), "phi only": (0, ANGLE, "phi", 0.3),
                "x only": (POSITION, 0, "x", 0.3),
                "paper x0.5": (POSITION / 2, ANGLE / 2, "all", 0.3),
                "paper x2": (2 * POSITION, 2 * ANGLE, "all", 0.3),
                "paper, sigma 0.2 s": (POSITION, ANGLE, "all", 0.2),
                "paper, sigma 0.5 s": (POSITION, ANGLE, "all", 0.5)}
    errs = {(v, m): [] for v in variants for m in ("3dof", "2dof")}
    for s in range(args.first_seed, args.first_seed + args.trajectories):
        run = simulate("deceleration", 15.0, params=TABLE3, rider=rider, seed=s)
        clean = motion_capture(run, TABLE3, noise="none")
        truth = fit(clean)
        truth["3dof"] = TABLE3.h
        for j in range(args.draws):
            seed = 1000 * s + j
            for name, (pos, ang, chan, sigma) in variants.items():
                if chan == "all":
                    rec = motion_capture(run, TABLE3, noise=(pos, ang), seed=seed)
                else:
                    rec = clean.copy()
                    rng = np.random.default_rng([seed, 7])
                    rec[chan] = rec[chan] + rng.normal(0.0, pos if chan == "x" else ang, len(rec))
                for m, h in fit(rec, sigma).items():
                    errs[(name, m)].append(h - truth[m])
        print(f"trajectory {s} done", file=sys.stderr, flush=True)
    print(f"{'variant':<20} {'model':<5} {'mean err [mm]':>13} {'sd [mm]':>8} {'se [mm]':>8}")
    for (name, m), e in errs.items():
        e = 1e3 * np.asarray(e)
        print(f"{name:<20} {m:<5} {e.mean():+13.2f} {e.std(ddof=1):8.2f} {e.std(ddof=1) / math.sqrt(e.size):8.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
