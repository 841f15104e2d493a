"""How far a real ride's battery power is from itself, band by band: its first half against its second.

    python studies/band_halves.py [--data ../shared/data]

The yardstick of the held-out level-and-spectrum score (``simulation.steps[].heldout_bands``,
:func:`euc_sim.rides.grids.rider_features.band_ratio_db`): a simulated ride whose battery power is
as far from the log's, band by band, as one half of the real ride is from the other has the
ride's level and spectrum as well as the ride itself keeps them.  For every shared euc_core
log with battery power it prints a markdown row: the RMS over the eight bands (~2 Hz to
~0.1 Hz) of 20·log10(second half's band RMS / first half's), dB, and the fastest and
slowest band's ratio.  The halves are split at the median time stamp; the log is on the
rider fit's 10 Hz grid (:func:`euc_sim.rides.grids.rider_features.log_channels`), not smoothed.
Exit 2 on a missing data folder.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"


def half_ratio_db(t, P, segment, rate: float) -> list[float]:
    """20·log10 of the second half's band RMS over the first half's, per band, dB.

    Parameters
    ----------
    t, P : array_like
        s and W on one uniform grid.
    segment : array_like of int
        The grid's segments (the bands' smoothers never cross one).
    rate : float
        Hz.

    Returns
    -------
    list of float
        One ratio per band of :data:`euc_sim.rides.grids.rider_features.BAND_WINDOWS`, fastest first.
    """
    import numpy as np

    from euc_sim.rides.grids.rider_features import band_features

    t, P = np.asarray(t, float), np.asarray(P, float)
    second = t >= np.median(t)
    a = band_features(P, segment, rate, ~second)
    b = band_features(P, segment, rate, second)
    return [float(x) for x in 20.0 / math.log(10.0) * (b - a)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(SHARED), help="the shared data folder")
    args = ap.parse_args(argv)
    data = Path(args.data)
    trips = sorted(p for p in (data / "euc_core" / "trips").glob("*/*/*/*.csv") if p.name != "meta.csv")
    if not trips:
        print(f"band_halves: --data {data}: no euc_core trip logs there", file=sys.stderr)
        return 2
    import warnings

    import numpy as np

    from euc_sim.rides.grids.rider_features import RiderFitError, log_channels

    print("| log | second half against first: RMS over the bands dB | fastest band dB | slowest band dB |")
    print("| --- | --- | --- | --- |")
    for path in trips:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                ch = log_channels(path)
                r = half_ratio_db(ch["t"], ch["P"], ch["segment"].to_numpy(), 10.0)
            except (RiderFitError, ValueError) as exc:
                print(f"| {path.relative_to(data)} | not read: {exc} | | |")
                continue
        print(f"| {path.relative_to(data)} | {math.sqrt(np.mean(np.square(r))):.1f} | {r[0]:+.1f} | "
              f"{r[-1]:+.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
