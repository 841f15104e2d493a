"""Measured the simulated rider's closed-loop gain from a wiggling plan to speed, frequency by frequency: docs/ride_simulation.md.

How the simulated rider rides a wiggling plan: the closed loop's gain from plan to speed.

    python studies/rider_loop_gain.py [--speed 10] [--amplitude 0.3] [--extra-mass 40]
        [--delay 0.15] [--anticipation 0.3] [--learn]

The default LQR rider (:func:`euc_sim.simulation.engine.default_rider`, paper's PD, Table 3
with ``--extra-mass`` kg added to the rider) rides a plan v(t) = speed + amplitude·sin(2πft)
for 40 s at each f (:func:`euc_sim.rides.sim.tracking.simulate_profile`, no acceleration limit), no
plan correction unless ``--learn`` (one correction: the plan learned through the inverted loop,
:mod:`euc_sim.rides.sim.plan_learning`).  Printed per f: the simulated speed's amplitude over the
plan's and its phase (a sine fitted after the first 10 s).  Deterministic (no motor noise).
"""

from __future__ import annotations

import argparse
import sys

FREQS = (0.1, 0.2, 0.3, 0.5, 0.7, 1.0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speed", type=float, default=10.0)
    ap.add_argument("--amplitude", type=float, default=0.3)
    ap.add_argument("--extra-mass", type=float, default=40.0)
    ap.add_argument("--delay", type=float, default=0.15)
    ap.add_argument("--anticipation", type=float, default=0.3)
    ap.add_argument("--learn", action="store_true")
    args = ap.parse_args(argv)
    for name in ("speed", "amplitude", "delay", "anticipation"):
        val, zero_ok = getattr(args, name), name in ("delay", "anticipation")
        if not (val >= 0 if zero_ok else val > 0):
            need = "non-negative" if zero_ok else "positive"
            print(f"rider_loop_gain: --{name} {val}: must be {need}", file=sys.stderr)
            return 2
    import numpy as np

    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.sim.tracking import simulate_profile
    from euc_sim.simulation.engine import default_rider

    p = TABLE3.replace(m=TABLE3.m + args.extra_mass)
    rider = default_rider(p).replace(delay=args.delay, anticipation=args.anticipation)
    print("| f Hz | speed amplitude / plan amplitude | phase deg |")
    print("| --- | --- | --- |")
    for f in FREQS:
        t = np.arange(0.0, 40.0, 0.1)
        v = args.speed + args.amplitude * np.sin(2 * np.pi * f * t)
        run = simulate_profile(t, v, p, {}, track_iterations=1 if args.learn else 0, lean_share=None, rider=rider)
        df = run.frame
        tt, x = df["t"].to_numpy(), df["x_dot"].to_numpy()
        sel = tt > 10.0
        X = np.column_stack([np.sin(2 * np.pi * f * tt[sel]), np.cos(2 * np.pi * f * tt[sel]), np.ones(sel.sum())])
        b = np.linalg.lstsq(X, x[sel], rcond=None)[0]
        print(f"| {f:g} | {np.hypot(b[0], b[1]) / args.amplitude:.2f} | {np.degrees(np.arctan2(b[1], b[0])):.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
