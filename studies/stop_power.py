"""Is anybody balancing the wheel while it stands?  The battery power at the logs' stands.

    python studies/stop_power.py [--data ../shared/data] [--v-max 0.1] [--min-duration 3]

For every shared real log (``euc_core/trips/*/*/N/N.csv`` and ``wheellog/*.csv``) it finds the
stands of :func:`euc_sim.rides.grids.stops.find_stops` on the log's smoothed speed
(:func:`euc_sim.rides.grids.signals.ride_signals`): stops lasting ``--min-duration`` s or more, and the
shorter stands below ``--v-max``.  It prints a markdown row per log: the stops' count and
seconds, the battery power's |P| median and 90th percentile on the stop rows, on the shorter
stands and while riding.  A rider balancing a standing wheel makes its motor work; a wheel
that draws nothing while standing has nobody balancing on it (a foot down, or nobody on it
yet): the evidence for the stop model of :mod:`euc_sim.rides.grids.stops`.  Exit 2 on a missing
data folder.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"


def log_paths(data: Path) -> list[Path]:
    """The shared real logs under ``data`` (euc_core trips and WheelLog), sorted."""
    trips = [p for p in sorted((data / "euc_core" / "trips").glob("*/*/*/*.csv")) if p.name != "meta.csv"]
    return trips + sorted((data / "wheellog").glob("*.csv"))


def stand_power(t, v, P, v_max: float, min_duration: float) -> dict:
    """|P| at the stops, at shorter stands and while riding (W), and the stops' count and seconds.

    Parameters
    ----------
    t, v, P : array_like
        s, m/s and W on one grid.
    v_max, min_duration : float
        m/s and s, as :func:`euc_sim.rides.grids.stops.find_stops`.

    Returns
    -------
    dict
        ``stops`` (count), ``stop_s`` (s) and, for ``stop``, ``short`` and ``riding``, the
        (median, 90th percentile) of |P|, W (None where there are no such rows).
    """
    import numpy as np

    from euc_sim.rides.grids.stops import find_stops

    t, v, P = (np.asarray(a, float) for a in (t, v, P))
    stops = find_stops(t, v, v_max, min_duration)
    at_stop = np.zeros(t.size, bool)
    for a, b in stops:
        at_stop[a:b + 1] = True
    still = np.abs(v) < v_max
    out = {"stops": len(stops), "stop_s": float(sum(t[b] - t[a] for a, b in stops))}
    for name, rows in (("stop", at_stop), ("short", still & ~at_stop), ("riding", ~still)):
        p = np.abs(P[rows & np.isfinite(P)])
        out[name] = tuple(float(x) for x in np.percentile(p, [50, 90])) if p.size else None
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(SHARED), help="the shared data folder")
    ap.add_argument("--v-max", type=float, default=None, help="m/s (default stops.V_STOP)")
    ap.add_argument("--min-duration", type=float, default=None, help="s (default stops.T_STOP)")
    args = ap.parse_args(argv)
    from euc_sim.rides.grids.stops import T_STOP, V_STOP

    data = Path(args.data)
    paths = log_paths(data) if data.is_dir() else []
    if not paths:
        print(f"stop_power: --data {data}: no euc_core or wheellog logs there", file=sys.stderr)
        return 2
    v_max = V_STOP if args.v_max is None else args.v_max
    min_duration = T_STOP if args.min_duration is None else args.min_duration
    from euc_sim.rides.grids.signals import ride_signals

    fmt = lambda q: "–" if q is None else f"{q[0]:.0f} / {q[1]:.0f}"     # noqa: E731
    print(f"| log | stops ≥ {min_duration:g} s (s) | |P| at stops W, median / p90 | shorter stands | riding |")
    print("| --- | --- | --- | --- | --- |")
    for path in paths:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                frame = ride_signals(path).frame
            except ValueError as exc:
                print(f"| {path.relative_to(data)} | not read: {exc} | | | |")
                continue
        r = stand_power(frame["t"], frame["v"], frame["P"], v_max, min_duration)
        print(f"| {path.relative_to(data)} | {r['stops']} ({r['stop_s']:.0f}) | {fmt(r['stop'])} | "
              f"{fmt(r['short'])} | {fmt(r['riding'])} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
