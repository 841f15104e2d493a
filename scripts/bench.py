#!/usr/bin/env python
"""euc-sim benchmarks: speed as ratios against a reference run in the same process.

Machines are noisy, so every figure is a ratio of two timings taken here and now;
nothing is asserted.  Run all sections, or some:

    python scripts/bench.py                 # everything
    python scripts/bench.py inverse         # one section
    python scripts/bench.py --list

Each section is a function ``bench_NAME() -> dict`` registered in ``SECTIONS``; it
prints its own lines and returns its figures (printed again as JSON at the end).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import Callable

import numpy as np

os.environ.setdefault("MPLBACKEND", "Agg")


def timed(fn: Callable[[], object], repeat: int = 3) -> float:
    """Best wall time of ``repeat`` runs, s."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


# --- issue 2: vectorised analytic inverse dynamics ---------------------------------------
def bench_inverse() -> dict:
    """Samples/s of the vectorised analytic inverse dynamics vs mj_inverse and mj_step loops."""
    import mujoco

    from euc_sim import analytic
    from euc_sim.crosscheck import random_states
    from euc_sim.mujoco_model import EucMujoco, to_mujoco
    from euc_sim.parameters import TABLE3

    n_vec, n_loop = 200_000, 20_000
    q, qd, qdd = random_states(n_vec, seed=0)
    t_vec = timed(lambda: analytic.torques(TABLE3, q, qd, qdd))
    t_vec_id = timed(lambda: analytic.inverse_dynamics(TABLE3, q, qd, qdd))

    sim = EucMujoco()
    m, d = sim.model, sim.data
    qpos, qvel, qacc = to_mujoco(sim.index, TABLE3.R, q[:n_loop], qd[:n_loop], qdd[:n_loop])

    def inverse_loop():
        for i in range(n_loop):
            d.qpos[:] = qpos[i]
            d.qvel[:] = qvel[i]
            d.qacc[:] = qacc[i]
            mujoco.mj_inverse(m, d)

    def step_loop():
        sim.set_state([0.0, 0.0, 0.0])
        for _ in range(n_loop):
            mujoco.mj_step(m, d)

    n_py = 5_000

    def analytic_loop():
        for i in range(n_py):
            analytic.inverse_dynamics(TABLE3, q[i], qd[i], qdd[i])

    t_py = timed(analytic_loop)
    t_inv = timed(inverse_loop)
    t_step = timed(step_loop)
    rate = {
        "analytic_vectorised_torques_per_s": n_vec / t_vec,
        "analytic_vectorised_inverse_dynamics_per_s": n_vec / t_vec_id,
        "mj_inverse_loop_per_s": n_loop / t_inv,
        "analytic_per_sample_loop_per_s": n_py / t_py,
        "mj_step_loop_per_s": n_loop / t_step,
    }
    rate["ratio_vectorised_vs_mj_inverse_loop"] = rate["analytic_vectorised_inverse_dynamics_per_s"] / rate["mj_inverse_loop_per_s"]
    rate["ratio_vectorised_vs_analytic_loop"] = rate["analytic_vectorised_inverse_dynamics_per_s"] / rate["analytic_per_sample_loop_per_s"]
    rate["ratio_vectorised_vs_mj_step_loop"] = rate["analytic_vectorised_inverse_dynamics_per_s"] / rate["mj_step_loop_per_s"]
    print(f"  vectorised inverse dynamics : {rate['analytic_vectorised_inverse_dynamics_per_s']:12.0f} samples/s")
    print(f"  vectorised M_d1, M_d2, M_h  : {rate['analytic_vectorised_torques_per_s']:12.0f} samples/s")
    print(f"  mj_inverse per-sample loop  : {rate['mj_inverse_loop_per_s']:12.0f} samples/s")
    print(f"  analytic per-sample loop    : {rate['analytic_per_sample_loop_per_s']:12.0f} samples/s")
    print(f"  mj_step loop                : {rate['mj_step_loop_per_s']:12.0f} steps/s")
    print(f"  ratio vectorised / mj_inverse loop = {rate['ratio_vectorised_vs_mj_inverse_loop']:.1f}x (aim ≥ 50x)")
    print(f"  ratio vectorised / analytic loop   = {rate['ratio_vectorised_vs_analytic_loop']:.1f}x")
    print(f"  ratio vectorised / mj_step loop    = {rate['ratio_vectorised_vs_mj_step_loop']:.1f}x")
    return rate


SECTIONS: dict[str, Callable[[], dict]] = {
    "inverse": bench_inverse,
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
