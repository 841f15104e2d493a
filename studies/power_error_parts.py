"""Showed where a simulated ride's held-out battery-power error lies (level, time scales, peaks): docs/ride_simulation.md.

Where a simulated ride's held-out battery-power error lies: level, time scales, peaks.

    python studies/power_error_parts.py REPORT_DIR [REPORT_DIR ...] [--step drivetrain]

Each REPORT_DIR is the ``--report`` folder of ``euc-sim ride FIT --compare HELD`` (its
``ride_simulation.csv``: logged and simulated battery power per 0.1 s row of HELD, ``scored``;
its ``ride_balance.csv``: the balance fit's held-out prediction ``P_augmented``).  On the scored
rows, for the balance fit and for the simulated step (default ``drivetrain``), the error
e = predicted − logged is split into its mean (level), a slow part (20 s moving mean, less the
level), a middle part (2 s moving mean less the 20 s one) and a fast part (the rest), each given
as an RMS in W (their squares add up to the total's up to the small cross terms), and the
share of the squared error on the 5 % of rows with the largest logged |P| (peaks).  Then the
predicted and logged power's own RMS in the middle and fast bands (spectrum: above 1, the
prediction moves more than the log).  For the simulated step, the last columns relate its error
to its speed tracking: the RMS of simulated − logged speed, the share of the squared error on
the rows where they differ by more than 0.5 m/s, and the ratio of the step's RMS error to the
balance fit's on the rows where they differ by less than 0.2 m/s (the ratio where the rider
rode the logged speed).  One markdown row per report and model.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

SLOW, MID = 20.0, 2.0          # s, moving-mean windows


def _mean(x, n: int):
    import numpy as np
    from scipy.ndimage import uniform_filter1d

    return uniform_filter1d(np.asarray(x, float), max(int(n), 1), mode="nearest")


def parts(logged, pred, rate: float = 10.0) -> dict:
    """The split of ``pred − logged`` (W) described in the module docstring."""
    import numpy as np

    e = np.asarray(pred, float) - np.asarray(logged, float)
    lvl = float(np.mean(e))
    s20, s2 = _mean(e, SLOW * rate), _mean(e, MID * rate)
    band = lambda x: (_mean(x, MID * rate) - _mean(x, SLOW * rate), x - _mean(x, MID * rate))  # noqa: E731
    (pm, pf), (lm, lf) = band(np.asarray(pred, float)), band(np.asarray(logged, float))
    top = np.abs(logged) >= np.quantile(np.abs(logged), 0.95)
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    return {"total": rms(e), "level": lvl, "slow": rms(s20 - lvl), "mid": rms(s2 - s20),
            "fast": rms(e - s2), "peak_share": float(np.sum(e[top] ** 2) / np.sum(e ** 2)),
            "mid_ratio": rms(pm) / rms(lm), "fast_ratio": rms(pf) / rms(lf)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("reports", nargs="+")
    ap.add_argument("--step", default="drivetrain")
    args = ap.parse_args(argv)
    import numpy as np
    import pandas as pd

    print("| pair | model | total W | level W | slow (> 20 s) W | middle (2–20 s) W | fast (< 2 s) W | "
          "share of e² on the 5 % peak rows | middle-band RMS, predicted / logged | fast-band RMS, predicted / logged | "
          "speed error RMS m/s | share of e² where the speeds differ by over 0.5 m/s | ratio to the balance fit where they differ by under 0.2 m/s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for rep in map(Path, args.reports):
        try:
            sim = pd.read_csv(rep / "ride_simulation.csv")
            bal = pd.read_csv(rep / "ride_balance.csv")
        except (OSError, ValueError) as exc:
            print(f"power_error_parts: {rep}: {exc}", file=sys.stderr)
            return 2
        col = f"P_{args.step}"
        if col not in sim or "P_augmented" not in bal:
            print(f"power_error_parts: {rep}: no column {col} or P_augmented", file=sys.stderr)
            return 2
        sim["t"], bal["t"] = sim["t"].round(2), bal["t"].round(2)
        m = sim.merge(bal[["t", "P_augmented"]], on="t", how="left")
        ok = m["scored"].astype(bool) & m["P_augmented"].notna() & m[col].notna()
        name = rep.parent.name if rep.name == "report" else rep.name
        d = m.loc[ok]
        dv = (d[f"v_{args.step}"] - d["v_log"]).abs().to_numpy()
        e_sim = (d[col] - d["P_log"]).to_numpy()
        e_bal = (d["P_augmented"] - d["P_log"]).to_numpy()
        near = dv < 0.2
        track = (f"{np.sqrt(np.mean(dv ** 2)):.2f} | {100 * np.sum(e_sim[dv > 0.5] ** 2) / np.sum(e_sim ** 2):.0f} % | "
                 f"{np.sqrt(np.mean(e_sim[near] ** 2) / np.mean(e_bal[near] ** 2)):.2f} ({100 * near.mean():.0f} % of rows)")
        for label, c in (("balance fit", "P_augmented"), (args.step, col)):
            p = parts(d["P_log"].to_numpy(), d[c].to_numpy())
            print(f"| {name} | {label} | {p['total']:.0f} | {p['level']:+.0f} | {p['slow']:.0f} | {p['mid']:.0f} | "
                  f"{p['fast']:.0f} | {100 * p['peak_share']:.0f} % | {p['mid_ratio']:.2f} | {p['fast_ratio']:.2f} | "
                  + (track if c == col else "– | – | –") + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
