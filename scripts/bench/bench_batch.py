"""Benchmarks of many rides at once (``scripts/bench.py`` sections ``dataset`` and ``batch``):
datasets on processes, the analytic batch engine, MuJoCo batches on threads."""

from __future__ import annotations

import os
import time

from bench_timing import at_once, timed, timed_together


def bench_dataset() -> dict:
    """Dataset throughput (recordings/s): one process vs all cores."""
    import tempfile

    from euc_sim.simulation.dataset import dataset_plan, run_dataset

    cores = os.cpu_count() or 1
    counts = (("constant_speed", 2 * cores), ("deceleration", 2 * cores))
    specs = dataset_plan(seed=0, duration=10.0, counts=counts)
    with tempfile.TemporaryDirectory() as tmp:
        t1 = timed(lambda: run_dataset(f"{tmp}/one", specs, workers=1, progress=False), repeat=1)
        tn = timed(lambda: run_dataset(f"{tmp}/all", specs, workers=cores, progress=False), repeat=1)
    out = {"recordings": len(specs), "cores": cores, "one_core_per_s": len(specs) / t1,
           "all_cores_per_s": len(specs) / tn}
    out["speedup"] = t1 / tn
    print(f"  {len(specs)} recordings of 10 s each")
    print(f"  1 process   : {out['one_core_per_s']:6.2f} recordings/s")
    print(f"  {cores} processes : {out['all_cores_per_s']:6.2f} recordings/s (speed-up {out['speedup']:.2f}x)")
    return out


# --- the batch engine ------------------------------------------------------------
def _batch_chunk(args) -> int:
    """Worker: one chunk of rides on the batch engine; returns how many fell."""
    from batch_engine import simulate_batch          # scripts/, on the path of scripts/bench.py
    from euc_sim.simulation.engine import default_rider
    from euc_sim.simulation.maneuvers import make_maneuver

    seeds, duration = args
    mans = [make_maneuver("stop_and_go", v=2.0 + 0.5 * (s % 3)) for s in seeds]
    run = simulate_batch(mans, duration, seeds=seeds, rider=default_rider(noise_std=3.0), stride=1000)
    return int(run.fell.sum())


def bench_batch(rides: int = 1000, duration: float = 20.0) -> dict:
    """Aggregate real-time factor of the batch engine (rides on all cores) beside the
    per-ride MuJoCo closed loop, in the same run."""
    from euc_sim.simulation.engine import default_rider, simulate
    from euc_sim.simulation.runner import run_tasks

    cores = os.cpu_count() or 1
    rider = default_rider(noise_std=3.0)
    simulate("stop_and_go", 0.1, rider=rider)                          # warm caches
    t_one = timed(lambda: simulate("stop_and_go", duration, rider=rider, seed=1), repeat=1)
    per = -(-rides // cores)
    chunks = [(f"chunk{i}", (list(range(i * per, min(rides, (i + 1) * per))), duration)) for i in range(cores)]
    t_serial_small = timed(lambda: _batch_chunk((list(range(50)), duration)), repeat=1)
    rep = None

    def parallel():
        nonlocal rep
        rep = run_tasks(_batch_chunk, chunks, workers=cores, progress=False)
    t_batch = timed(parallel, repeat=1)
    out = {"rides": rides, "duration_s": duration, "cores": cores,
           "per_ride_mujoco_real_time_factor": duration / t_one,
           "batch_50_rides_one_core_real_time_factor": 50 * duration / t_serial_small,
           "batch_aggregate_real_time_factor": rides * duration / t_batch,
           "batch_wall_s": t_batch, "fell": sum(rep.results.values()), "failed_chunks": len(rep.failed)}
    out["ratio_batch_vs_per_ride"] = out["batch_aggregate_real_time_factor"] / out["per_ride_mujoco_real_time_factor"]
    print(f"  per-ride MuJoCo closed loop      : {out['per_ride_mujoco_real_time_factor']:8.1f}x real time (aim ≥ 150x)")
    print(f"  batch engine, 50 rides, 1 core   : {out['batch_50_rides_one_core_real_time_factor']:8.1f}x real time")
    print(f"  batch engine, {rides} rides of {duration:g} s on {cores} cores: "
          f"{out['batch_aggregate_real_time_factor']:8.1f}x real time aggregate (aim ≥ 2000x), "
          f"{t_batch:.1f} s wall, {out['fell']} fell")
    print(f"  ratio batch aggregate / per-ride = {out['ratio_batch_vs_per_ride']:.1f}x")
    out.update(mujoco_batch_figures(rides, duration))
    return out


# --- MuJoCo batches on threads --------------------------------------------------
def _effect_requests(rides: int, duration: float) -> list[dict]:
    """``rides`` requests of :func:`simulate` with the catalog's effects the batch applies,
    varied per ride (drag, rolling resistance, slope, bearing friction, rider mass), seeded."""
    from euc_sim.simulation.engine import default_rider
    from euc_sim.simulation.maneuvers import make_maneuver

    rider = default_rider(noise_std=3.0)
    out = []
    for s in range(rides):
        eff = {"aerodynamic_drag": 0.3 + 0.05 * (s % 3), "rolling_resistance": 0.015 + 0.005 * (s % 2),
               "road_slope": 0.01 * (s % 3), "wheel_bearing_friction": 0.05 * (s % 2)}
        out.append({"maneuver": make_maneuver("stop_and_go", v=2.0 + 0.5 * (s % 3)), "duration": duration,
                    "seed": s, "rider": rider, "effects": eff})
    return out


def mujoco_batch_figures(rides: int = 1000, duration: float = 20.0, chunk: int = 25) -> dict:
    """Aggregate step rate of :func:`euc_sim.simulation.mujoco_batch.simulate_rides` on 1 and 2
    threads (``rides`` rides with effects, one call, in batches of ``chunk``: a ride's records
    take 1.3 MB) over the bare single-thread ``mj_step`` rate of the same model, same process;
    beside it the machine's ceiling: two bare ``mj_step`` loops on two threads at once
    (``mj_step`` releases the GIL) over two bare loops' rate."""
    import mujoco

    from euc_sim.simulation.mujoco_batch import _batch_model, simulate_rides
    from euc_sim.simulation.engine import prepare

    reqs = _effect_requests(rides, duration)
    steps = int(round(duration / 1e-3))
    ride = prepare(**reqs[1])
    m = _batch_model(ride, {})
    d = mujoco.MjData(m)
    simulate_rides(reqs[:2], nthread=2)                                # compile, warm caches
    fell = 0

    def bare(forces=False, d=d):
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = ride.stepper.d.qpos, ride.stepper.d.qvel
        if forces:     # the MuJoCo work of the effects: a drag force at G and a rolling moment, held
            d.xfrc_applied[ride.stepper.b_rider, 0] = -2.0
            d.qfrc_applied[ride.stepper.vx] = -1.0
        mujoco.mj_step(m, d, nstep=steps)

    pair = [mujoco.MjData(m) for _ in range(2)]

    def bare_two_threads():
        at_once(bare, [{"d": d2} for d2 in pair])

    def batch(nthread, part):
        def run():
            nonlocal fell
            res = simulate_rides(part, nthread=nthread, batch=chunk)
            fell += sum(isinstance(r, Exception) for r in res)
        return run

    small = reqs[:min(rides, 20)]       # best of 3, interleaved with the bare loop: load-robust
    t = timed_together({"bare": lambda: [bare() for _ in small], "one": batch(1, small)}, repeat=3)
    t_bare = timed(bare, repeat=3)
    t_forces = timed(lambda: bare(True), repeat=3)
    ceiling = timed_together({"one": bare, "two": bare_two_threads}, repeat=5)
    cpu_bare = min(_cpu_seconds(bare, time.thread_time) for _ in range(3))
    cpu0 = time.process_time()                 # CPU seconds of every thread of the process
    t_two = timed(batch(2, reqs), repeat=1)
    cpu_two = time.process_time() - cpu0
    rate_bare = steps / t_bare
    rate_one_bare = len(small) * steps / t["bare"]
    out = {"mujoco_batch_rides": rides, "mujoco_batch_duration_s": duration,
           "bare_mj_step_per_s": rate_bare,
           "mujoco_batch_1_thread_steps_per_s": len(small) * steps / t["one"],
           "mujoco_batch_2_threads_steps_per_s": rides * steps / t_two,
           "mujoco_batch_2_threads_real_time_factor": rides * duration / t_two,
           "mujoco_batch_wall_s": t_two, "mujoco_batch_fell": fell}
    out["mujoco_batch_1_thread_vs_bare"] = out["mujoco_batch_1_thread_steps_per_s"] / rate_one_bare
    out["mujoco_batch_thread_scaling"] = out["mujoco_batch_2_threads_steps_per_s"] / (2 * rate_bare)
    out["bare_mj_step_with_applied_forces_per_s"] = steps / t_forces
    out["bare_two_threads_scaling"] = ceiling["one"] / ceiling["two"]     # (2 steps / t_two) / (2 steps / t_one)
    out["mujoco_batch_thread_scaling_of_ceiling"] = out["mujoco_batch_thread_scaling"] / out["bare_two_threads_scaling"]
    # the work: a bare ride's CPU time over a batch ride's (every thread, set-up and DataFrames in);
    # with no core idle the scaling reaches this times the ceiling, no more
    out["mujoco_batch_2_threads_cpu_efficiency"] = cpu_bare * rides / cpu_two
    out["mujoco_batch_thread_scaling_vs_bare_with_forces"] = (out["mujoco_batch_2_threads_steps_per_s"]
                                                              * t_forces / (2 * steps))
    print(f"  bare mj_step (C loop, 1 thread)  : {rate_bare / 1e3:8.1f} k steps/s")
    print(f"  MuJoCo batch, {len(small)} rides, 1 thread: {out['mujoco_batch_1_thread_steps_per_s'] / 1e3:8.1f} "
          f"k steps/s = {out['mujoco_batch_1_thread_vs_bare']:.2f} x bare")
    print(f"  MuJoCo batch, {rides} rides of {duration:g} s with effects, 2 threads: "
          f"{out['mujoco_batch_2_threads_steps_per_s'] / 1e3:8.1f} k steps/s, "
          f"{out['mujoco_batch_2_threads_real_time_factor']:.0f}x real time, {t_two:.1f} s wall")
    print(f"  ratio 2-thread batch / (2 x bare) = {out['mujoco_batch_thread_scaling']:.2f} (aim >= 0.85); "
          f"against a bare step with the effects' applied forces: "
          f"{out['mujoco_batch_thread_scaling_vs_bare_with_forces']:.2f}")
    print(f"  ceiling: 2 bare mj_step loops on 2 threads at once / (2 x bare) = "
          f"{out['bare_two_threads_scaling']:.2f}; the batch's ratio is "
          f"{out['mujoco_batch_thread_scaling_of_ceiling']:.2f} of it")
    print(f"  CPU time of a bare ride / of a batch ride (2 threads, set-up and DataFrames in) = "
          f"{out['mujoco_batch_2_threads_cpu_efficiency']:.2f}: the ratio's bound with no core idle")
    return out


def _cpu_seconds(fn, clock) -> float:
    """CPU seconds of ``fn()`` by ``clock`` (``time.thread_time``: this thread's)."""
    c0 = clock()
    fn()
    return clock() - c0
