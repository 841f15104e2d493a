#!/usr/bin/env python
"""euc-sim benchmarks: speed as ratios against a reference run in the same process.

Machines are noisy, so every figure is a ratio of two timings taken here and now;
nothing is asserted.  Run all sections, or some:

    python scripts/bench.py                 # everything
    python scripts/bench.py inverse         # one section
    python scripts/bench.py --list

Each section is a function ``bench_NAME() -> dict`` registered in ``SECTIONS``; it
prints its own lines and returns its figures (written as JSON with ``--json``).  The
sections live beside this script by idea: ``bench_loops`` (the step and the closed
loops), ``bench_batch`` (many rides at once), ``bench_analysis`` (identification,
diagnosis), ``bench_rides`` (real and long rides), ``bench_spatial_threads`` (3-D rides on threads); ``bench_timing`` the timers.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Callable

if str(Path(__file__).resolve().parent / "bench") not in sys.path:     # the section modules, in scripts/bench/
    sys.path.insert(0, str(Path(__file__).resolve().parent / "bench"))

from bench_analysis import bench_diagnose, bench_identify, bench_uncertainty  # noqa: E402
from bench_batch import (_batch_chunk, _effect_requests, bench_batch, bench_dataset,  # noqa: E402,F401
                         mujoco_batch_figures)
from bench_loops import _replay, bench_closed_loop, bench_inverse, bench_spatial  # noqa: E402,F401
from bench_rides import (bench_ride, bench_ride_fast, bench_ride_mass, bench_ride_page,  # noqa: E402
                         bench_ride_page_serial)
from bench_spatial_threads import bench_spatial_threads  # noqa: E402
from bench_timing import timed, timed_together  # noqa: E402,F401


def bench_demo() -> dict:
    """euc-sim demo end to end (target: under 25 s on an idle 2-core machine) against one bare 15 s simulation."""
    import os
    import tempfile
    import time

    import euc_sim
    from euc_sim.api.demo import run_demo

    euc_sim.simulate("deceleration", 15.0, seed=1)                     # warm: imports, numba cache
    bare = timed(lambda: euc_sim.simulate("deceleration", 15.0, seed=1), repeat=3)
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run_demo(Path(tmp) / "demo", seed=1)
        demo = time.perf_counter() - t0
    print(f"  one bare 15 s simulation {bare:.2f} s; the demo {demo:.1f} s = {demo / bare:.0f}x it "
          f"(load average {load:.1f} on {os.cpu_count()} cores at the start)")
    return {"demo_seconds": demo, "bare_simulation_seconds": bare, "demo_vs_bare_simulation": demo / bare,
            "load_average": load, "cpu_count": os.cpu_count()}


SECTIONS: dict[str, Callable[[], dict]] = {
    "inverse": bench_inverse,
    "closed_loop": bench_closed_loop,
    "dataset": bench_dataset,
    "batch": bench_batch,
    "identify": bench_identify,
    "diagnose": bench_diagnose,
    "ride_mass": bench_ride_mass,
    "spatial": bench_spatial,
    "spatial_threads": bench_spatial_threads,
    "uncertainty": bench_uncertainty,
    "ride": bench_ride,
    "demo": bench_demo,
    "ride_page": bench_ride_page,
    "ride_page_serial": bench_ride_page_serial,
    "ride_fast": bench_ride_fast,
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sections", nargs="*", help="sections to run (default: all)")
    ap.add_argument("--list", action="store_true", help="list the sections")
    ap.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = ap.parse_args(argv)
    if args.list:
        for name, fn in SECTIONS.items():
            print(f"{name:12s} {fn.__doc__.splitlines()[0]}")
        return 0
    unknown = [s for s in args.sections if s not in SECTIONS]
    if unknown:
        print(f"bench: unknown section {unknown[0]!r}; valid: {', '.join(SECTIONS)}", file=sys.stderr)
        return 2
    results = {}
    for name in args.sections or SECTIONS:
        print(f"[{name}] {SECTIONS[name].__doc__.splitlines()[0]}", flush=True)
        results[name] = SECTIONS[name]()
    if args.json:
        from euc_sim.io import write_json
        write_json(args.json, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
