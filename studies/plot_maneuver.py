"""Draws a simulated maneuver as the paper's Fig. 6 panels (speed, γ, φ, torques), the figures of docs/simulation.md.

Plot a simulated maneuver: speed, γ, φ and the torques (the paper's Fig. 6 panels).

    python studies/plot_maneuver.py --maneuver deceleration --out docs/deceleration.png

Runs :func:`euc_sim.simulation.engine.simulate` (noise-free, MuJoCo) and, with ``--recording``,
overlays a recording's 120 Hz samples (e.g. one written by ``euc-sim simulate``).
"""

from __future__ import annotations

import argparse
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402


def plot(run: pd.DataFrame, title: str, recording: pd.DataFrame | None = None):
    """Figure with ẋ and v_ref, γ, φ (degrees) and M_d, M_h (N·m) against t (s)."""
    fig, ax = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    t = run["t"]
    ax[0].plot(t, run["x_dot"], label="ẋ")
    ax[0].plot(t, run["v_ref"], "--", label="v_ref (planned)")
    ax[0].set_ylabel("speed [m/s]")
    for i, (col, label) in enumerate((("gamma", "γ, EUC pitch"), ("phi", "φ, rider pitch")), start=1):
        if recording is not None:
            ax[i].plot(recording["t"], np.degrees(recording[col]), ".", ms=1.5, color="0.6",
                       label="120 Hz recording")
        ax[i].plot(t, np.degrees(run[col]), label=label)
        ax[i].axhline(0.0, color="k", lw=0.5)
        ax[i].set_ylabel(f"{col} [deg]")
    ax[3].plot(t, run["M_d"], label="M_d (motor)")
    ax[3].plot(t, run["M_h"], label="M_h (ankle)")
    ax[3].set_ylabel("torque [N·m]")
    ax[3].set_xlabel("t [s]")
    for a in ax:
        a.legend(loc="best", fontsize=8)
        a.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maneuver", default="deceleration")
    ap.add_argument("--duration", type=float, default=15.0)
    ap.add_argument("--engine", default="mujoco")
    ap.add_argument("--rider-noise", type=float, default=0.0, help="N·m")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--recording", help="overlay this recording's gamma and phi")
    ap.add_argument("--out", required=True, help="PNG file")
    args = ap.parse_args(argv)
    from euc_sim.io import atomic_write
    from euc_sim.simulation.engine import default_rider, simulate

    run = simulate(args.maneuver, args.duration, engine=args.engine, seed=args.seed,
                   rider=default_rider(noise_std=args.rider_noise))
    rec = pd.read_csv(args.recording) if args.recording else None
    fig = plot(run, f"{args.maneuver}: {args.engine} engine, Table 3, h = 0.6 m", rec)
    atomic_write(args.out, lambda p: fig.savefig(p, dpi=110, format="png"))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
