#!/usr/bin/env python
"""Showed that the rider's motor-noise level read from the recorded M_h matches the level simulated: docs/coverage.md.

The rider's motor-noise level read from the recorded M_h, against the level simulated.

Each ride is drawn as ``coverage_3d.py`` draws them (:func:`euc_sim.simulation.spatial.draw_spatial_ride`
from ``numpy.random.default_rng([SEED, 14])``) and ridden four times with the same seed at
rider motor noise σ = 0, 1.5, 3 and 6 N·m (paper sensor noise, which M_h does not carry);
:func:`euc_sim.diagnosis.rider_noise.motor_noise_level` reads each recording's level.  Prints
the level at σ = 0 and the range of level / σ at the others.

    python studies/rider_noise_check.py --seed 901 --rides 16

Seed 900 (8 rides) was looked at while choosing the estimator (tuning); 901 was run once after.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

LEVELS = (0.0, 1.5, 3.0, 6.0)


def check(seed: int, rides: int, duration: float = 20.0) -> dict:
    """Levels read over ``rides`` rides: ``zero`` (N·m at σ = 0), ``ratio`` (σ → level / σ list), ``fell``."""
    import pandas as pd

    from euc_sim.controllers.rider import Rider
    from euc_sim.diagnosis.rider_noise import motor_noise_level
    from euc_sim.simulation.spatial import draw_spatial_ride, write_spatial

    tau = Rider().noise_tau
    rng = np.random.default_rng([seed, 14])
    out = {"zero": [], "ratio": {s: [] for s in LEVELS[1:]}, "fell": 0}
    with tempfile.TemporaryDirectory() as d:
        for j in range(rides):
            ride = draw_spatial_ride(j, rng)
            ride_seed = int(rng.integers(1, 2**31 - 1))
            for sigma in LEVELS:
                f = Path(d) / f"r{j}_{sigma:g}.csv"
                try:
                    write_spatial(f, ride["path"], duration, seed=ride_seed, noise="paper", rider_noise=sigma,
                                  speed=ride["speed"], radius=ride["radius"])
                except ValueError:          # a fall: nothing written
                    out["fell"] += 1
                    continue
                df = pd.read_csv(f)
                level = motor_noise_level(df["t"].to_numpy(), df["M_h"].to_numpy(), tau)
                (out["zero"].append(level) if sigma == 0 else out["ratio"][sigma].append(level / sigma))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=901)
    ap.add_argument("--rides", type=int, default=16)
    args = ap.parse_args(argv)
    if args.rides < 1:
        print(f"--rides must be at least 1, got {args.rides}", file=sys.stderr)
        return 2
    warnings.simplefilter("ignore")
    r = check(args.seed, args.rides)
    print(f"seed [{args.seed}, 14]: {args.rides} rides × {len(LEVELS)} levels, {r['fell']} fell")
    if r["zero"]:
        print(f"  σ = 0: level {min(r['zero']):.3f} … {max(r['zero']):.3f} N·m")
    for sigma, ratios in r["ratio"].items():
        if ratios:
            print(f"  σ = {sigma:g} N·m: level / σ {min(ratios):.3f} … {max(ratios):.3f} "
                  f"(median {float(np.median(ratios)):.3f}, {len(ratios)} rides)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
