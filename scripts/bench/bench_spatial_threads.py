#!/usr/bin/env python
"""Benchmark of 3-D rides on threads (``scripts/bench.py`` section ``spatial_threads``).

``rides`` native 3-D rides of ``duration`` s (paths in turn, the study's rider with 3 N·m
motor noise, seeds 0 … rides-1) ridden by :func:`spatial_threads.ride_3d_many` (scripts/tables/)
on 1 and on 2 threads, in one process, interleaved (best of 3), beside the machine's ceiling:
two bare ``mj_step`` loops of ``mjcf/euc_3d.xml`` on two threads at once over one; and the
same rides as the blind study makes them (``write_spatial``: recording sampled, three files
written, under the GIL).

    python scripts/bench/bench_spatial_threads.py [--rides 8] [--duration 20]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

for _folder in (Path(__file__).resolve().parent, Path(__file__).resolve().parents[1] / "tables"):
    if str(_folder) not in sys.path:            # bench_timing; spatial_threads (the blind study's)
        sys.path.insert(0, str(_folder))

from bench_timing import at_once, timed_together  # noqa: E402

PATHS = ("circle", "slalom", "figure_eight", "u_turn")


def bench_spatial_threads(rides: int = 8, duration: float = 20.0) -> dict:
    """3-D rides on 2 threads: aggregate rate over 2 x the 1-thread rate, and the ceiling."""
    import mujoco

    from euc_sim.model.spatial import EucSpatial
    from euc_sim.simulation.engine import default_rider
    from euc_sim.simulation.spatial import simulate_3d, write_spatial
    from spatial_threads import ride_3d_many

    rider = default_rider(noise_std=3.0)
    reqs = [{"path": PATHS[s % len(PATHS)], "duration": duration, "seed": s, "rider": rider} for s in range(rides)]
    for p in PATHS:                                            # designs cached, callback built
        simulate_3d(p, 0.1, rider=rider)
    steps = int(round(duration / 1e-3))
    sims = [EucSpatial() for _ in range(2)]

    def bare(sim=sims[0]):
        sim.set_straight(2.0)
        mujoco.mj_step(sim.model, sim.data, nstep=steps)

    def bare_two():
        at_once(bare, [{"sim": s} for s in sims])

    fell = []
    tmp = tempfile.TemporaryDirectory()
    writes = [{"out": Path(tmp.name) / f"r{i}.csv", "path": r["path"], "duration": duration, "seed": r["seed"],
               "rider_noise": 3.0} for i, r in enumerate(reqs)]
    load0 = os.getloadavg()
    t = timed_together({"one": lambda: fell.append(ride_3d_many(reqs, nthread=1)),
                        "two": lambda: fell.append(ride_3d_many(reqs, nthread=2)),
                        "bare_one": bare, "bare_two": bare_two,
                        "write_one": lambda: ride_3d_many(writes, nthread=1, ride=write_spatial),
                        "write_two": lambda: ride_3d_many(writes, nthread=2, ride=write_spatial)}, repeat=3)
    load1 = os.getloadavg()
    tmp.cleanup()
    out = {"rides": rides, "duration_s": duration, "cores": os.cpu_count(),
           "rides_1_thread_real_time_factor": rides * duration / t["one"],
           "rides_2_threads_real_time_factor": rides * duration / t["two"],
           "bare_mj_step_3d_real_time_factor": duration / t["bare_one"],
           "fell": sum(isinstance(r, Exception) for r in fell[-1]),
           "load_average_1min": [load0[0], load1[0]]}
    out["threads_3d_scaling"] = t["one"] / (2 * t["two"])                  # (N / t2) / (2 N / t1)
    out["bare_two_threads_scaling"] = t["bare_one"] / t["bare_two"]       # (2 K / t2) / (2 K / t1)
    out["threads_3d_scaling_of_ceiling"] = out["threads_3d_scaling"] / out["bare_two_threads_scaling"]
    out["ride_cost_vs_bare_step"] = t["one"] / (rides * t["bare_one"])
    out["write_spatial_threads_scaling"] = t["write_one"] / (2 * t["write_two"])
    out["write_spatial_1_thread_real_time_factor"] = rides * duration / t["write_one"]
    print(f"  {rides} 3-D rides of {duration:g} s, {out['fell']} fell; load average {load0[0]:.2f} -> {load1[0]:.2f}")
    print(f"  1 thread : {out['rides_1_thread_real_time_factor']:7.0f}x real time aggregate "
          f"({out['ride_cost_vs_bare_step']:.2f} x a bare mj_step ride)")
    print(f"  2 threads: {out['rides_2_threads_real_time_factor']:7.0f}x real time aggregate")
    print(f"  ratio 2-thread aggregate / (2 x 1-thread) = {out['threads_3d_scaling']:.2f}")
    print(f"  ceiling: 2 bare mj_step loops on 2 threads / (2 x 1) = {out['bare_two_threads_scaling']:.2f}; "
          f"the rides reach {out['threads_3d_scaling_of_ceiling']:.2f} of it")
    print(f"  as the blind study makes them (write_spatial, 1 thread "
          f"{out['write_spatial_1_thread_real_time_factor']:.0f}x real time): "
          f"ratio 2-thread / (2 x 1-thread) = {out['write_spatial_threads_scaling']:.2f}")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rides", type=int, default=8)
    ap.add_argument("--duration", type=float, default=20.0, help="s")
    args = ap.parse_args(argv)
    if args.rides < 1 or not args.duration > 0:
        print("bench_spatial_threads: --rides must be >= 1 and --duration > 0", file=sys.stderr)
        return 2
    bench_spatial_threads(args.rides, args.duration)
    return 0


if __name__ == "__main__":
    sys.exit(main())
