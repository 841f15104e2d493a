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


def timed_together(fns: dict[str, Callable[[], object]], repeat: int = 5) -> dict[str, float]:
    """Best wall time of each, s, the runs interleaved (round robin): on a shared machine a
    burst of load then hits every contender of a ratio alike, not one of them."""
    best = {k: float("inf") for k in fns}
    for _ in range(repeat):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            best[k] = min(best[k], time.perf_counter() - t0)
    return best


# --- issue 2: vectorised analytic inverse dynamics ---------------------------------------
def bench_inverse() -> dict:
    """Samples/s of the vectorised analytic inverse dynamics vs mj_inverse and mj_step loops."""
    import mujoco

    from euc_sim.model import analytic
    from euc_sim.model.crosscheck import random_states
    from euc_sim.model.mujoco_model import EucMujoco, to_mujoco
    from euc_sim.model.parameters import TABLE3

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


# --- issue 3: closed-loop simulation -------------------------------------------------------
def bench_closed_loop() -> dict:
    """Closed-loop real-time factor at 1 kHz on one core vs bare mj_step loops.

    The closed loop is :func:`simulate`'s default, the native loop (the motor PD a numba
    MuJoCo control callback, issue 23); the Python loop (``native=False``) beside it.

    Beside the model the closed loop runs (ideal variant, reduced coordinates, RK4),
    the bare step of the XML as written (wheel hinge + rolling equality, the model
    before issue 15) and of the same reduced model with a one-evaluation integrator
    (semi-implicit Euler): what 150x would need.
    """
    import mujoco

    from euc_sim.model.mujoco_model import MJCF_PATH, EucMujoco
    from euc_sim.simulation.engine import default_rider, simulate

    duration = 15.0
    n = int(duration / 1e-3)
    sim = EucMujoco()
    m, d = sim.model, sim.data
    constrained = mujoco.MjModel.from_xml_path(str(MJCF_PATH))
    d_c = mujoco.MjData(constrained)
    euler = EucMujoco()
    euler.model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER

    def bare(model, data):
        def run():
            data.qpos[:] = 0.0
            data.qvel[:] = 0.0
            for _ in range(n):
                mujoco.mj_step(model, data)
        return run

    rider = default_rider(noise_std=3.0)
    simulate("stop_and_go", 0.1, rider=rider)                          # warm caches
    # the key ratio's two timings interleaved (a burst of load hits both), with the
    # per-ride setup (a ride of 10 steps: model, rider's trims and noise, DataFrame) and
    # the ride's torques replayed in C (the steps of the ride's own trajectory, no controller)
    together = timed_together({"bare": bare(m, d),
                               "loop": lambda: simulate("stop_and_go", duration, rider=rider, seed=1),
                               "setup": lambda: simulate("stop_and_go", 0.01, rider=rider, seed=1),
                               "replay": _replay(simulate("stop_and_go", duration, rider=rider, seed=1))})
    t_bare, t_loop, t_setup, t_replay = (together[k] for k in ("bare", "loop", "setup", "replay"))
    t_py = timed(lambda: simulate("stop_and_go", duration, rider=rider, seed=1, native=False))
    t_old = timed(bare(constrained, d_c))
    t_euler = timed(bare(euler.model, euler.data))
    t_eff = timed(lambda: simulate("stop_and_go", duration, rider=rider, seed=1,
                                   effects={"aerodynamic_drag": 0.4, "rolling_resistance": 0.02}))
    t_an = timed(lambda: simulate("stop_and_go", 1.0, rider=rider, engine="analytic"), repeat=1)
    out = {
        "bare_mj_step_real_time_factor": duration / t_bare,
        "closed_loop_real_time_factor": duration / t_loop,
        "bare_mj_step_constrained_xml_real_time_factor": duration / t_old,
        "bare_mj_step_euler_real_time_factor": duration / t_euler,
        "closed_loop_with_effects_real_time_factor": duration / t_eff,
        "analytic_engine_real_time_factor": 1.0 / t_an,
        "bare_step_us": t_bare / n * 1e6,
        "closed_loop_step_us": t_loop / n * 1e6,
    }
    out["closed_loop_cost_vs_bare_step"] = t_loop / t_bare          # native loop (issue 23)
    # the ratio's excess over 1, split: the ride's trajectory (its steps replayed in C cost more
    # than the bare loop's, which steps the model at rest), per-ride setup, and the rest: the callback
    out["closed_loop_trajectory_share_of_bare"] = (t_replay - t_bare) / t_bare
    out["closed_loop_setup_share_of_bare"] = t_setup / t_bare
    out["closed_loop_callback_share_of_bare"] = (t_loop - t_setup - t_replay) / t_bare
    out["closed_loop_python_cost_vs_bare_step"] = t_py / t_bare     # native=False
    out["closed_loop_cost_vs_replay_in_c"] = t_loop / t_replay      # vs the ride's torques in mujoco.rollout
    print(f"  bare mj_step loop (RK4, 1 ms)      : {out['bare_mj_step_real_time_factor']:7.1f}x real time "
          f"({out['bare_step_us']:.2f} us/step)")
    print(f"  closed loop, motor + rider, 1 kHz  : {out['closed_loop_real_time_factor']:7.1f}x real time "
          f"({out['closed_loop_step_us']:.2f} us/step; aim >= 150x = 6.67 us)")
    print(f"  bare step, XML with rolling equality: {out['bare_mj_step_constrained_xml_real_time_factor']:7.1f}x "
          f"real time (the model before issue 15)")
    print(f"  bare step, semi-implicit Euler     : {out['bare_mj_step_euler_real_time_factor']:7.1f}x real time "
          f"(one evaluation per step; not used: 2e-4 rad from the analytic engine)")
    print(f"  closed loop with drag + rolling    : {out['closed_loop_with_effects_real_time_factor']:7.1f}x real time")
    print(f"  analytic engine (solve_ivp/step)   : {out['analytic_engine_real_time_factor']:7.2f}x real time")
    print(f"  ratio closed loop / bare step time = {out['closed_loop_cost_vs_bare_step']:.2f} "
          f"(native callback; aim <= 1.11)")
    print(f"  ratio Python loop / bare step time = {out['closed_loop_python_cost_vs_bare_step']:.2f} "
          f"(native=False)")
    print(f"  excess over the bare step, of its time: the ride's own steps (replay - bare) "
          f"{out['closed_loop_trajectory_share_of_bare']:.3f}, per-ride setup "
          f"{out['closed_loop_setup_share_of_bare']:.3f}, callback (motor + rider) "
          f"{out['closed_loop_callback_share_of_bare']:.3f}")
    print(f"  ratio closed loop / replay in C     = {out['closed_loop_cost_vs_replay_in_c']:.2f} "
          f"(the same ride's torques open loop through mujoco.rollout: its states, no controller)")
    return out


def _replay(df):
    """The ride's held torques replayed open loop by ``mujoco.rollout`` on a fresh model, from its
    first state: the same RK4 steps over the same trajectory with no controller at all."""
    import mujoco
    from mujoco import rollout

    from euc_sim.model.mujoco_model import EucMujoco

    sim = EucMujoco()
    m, d = sim.model, sim.data
    act = lambda name: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name)   # noqa: E731
    ctrl = np.zeros((1, len(df) - 1, m.nu))
    ctrl[0, :, act("motor")] = df["M_d"].to_numpy()[:-1]
    ctrl[0, :, act("ankle")] = df["M_h"].to_numpy()[:-1]
    r0 = df.iloc[0]
    sim.set_state((r0.x, r0.gamma, r0.phi), (r0.x_dot, r0.gamma_dot, r0.phi_dot))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    x0 = np.zeros((1, mujoco.mj_stateSize(m, spec)))
    mujoco.mj_getState(m, d, x0[0], spec)
    return lambda: rollout.rollout(m, d, x0, ctrl)


# --- issue 14: the spatial closed loop ----------------------------------------------------
def bench_spatial() -> dict:
    """3-D closed loop (figure-eight, 1 kHz) real-time factor vs a bare mj_step loop of
    mjcf/euc_3d.xml, both timed here; the lateral design is cached before timing."""
    import mujoco

    from euc_sim.model.spatial import EucSpatial
    from euc_sim.simulation.spatial import simulate_3d

    duration = 10.0
    n = int(duration / 1e-3)
    sim = EucSpatial()
    m, d = sim.model, sim.data

    def bare():
        sim.set_straight(2.0)
        for _ in range(n):
            mujoco.mj_step(m, d)

    simulate_3d("figure_eight", 0.1)                                   # design and warm caches
    # the native loop (issue 23), the bare step and a 10-step ride (per-ride setup) interleaved
    together = timed_together({"bare": bare, "loop": lambda: simulate_3d("figure_eight", duration, seed=1),
                               "setup": lambda: simulate_3d("figure_eight", 0.01, seed=1)})
    t_bare, t_loop, t_setup = together["bare"], together["loop"], together["setup"]
    t_py = timed(lambda: simulate_3d("figure_eight", duration, seed=1, native=False), repeat=2)
    out = {"bare_mj_step_3d_real_time_factor": duration / t_bare,
           "closed_loop_3d_real_time_factor": duration / t_loop,
           "closed_loop_3d_python_real_time_factor": duration / t_py}
    out["closed_loop_3d_cost_vs_bare_step"] = t_loop / t_bare          # native loop (issue 23)
    out["closed_loop_3d_python_cost_vs_bare_step"] = t_py / t_bare     # native=False
    out["closed_loop_3d_setup_share_of_bare"] = t_setup / t_bare
    out["closed_loop_3d_callback_share_of_bare"] = (t_loop - t_setup - t_bare) / t_bare
    print(f"  bare mj_step loop, euc_3d (1 ms)   : {out['bare_mj_step_3d_real_time_factor']:7.1f}x real time")
    print(f"  3-D closed loop, figure-eight      : {out['closed_loop_3d_real_time_factor']:7.1f}x real time "
          f"(native callback; Python loop {out['closed_loop_3d_python_real_time_factor']:.1f}x)")
    print(f"  ratio closed loop / bare step time = {out['closed_loop_3d_cost_vs_bare_step']:.2f} "
          f"(aim <= 1/0.6 = 1.67; Python loop {out['closed_loop_3d_python_cost_vs_bare_step']:.2f})")
    print(f"  excess over the bare step: per-ride setup {out['closed_loop_3d_setup_share_of_bare']:.3f}, "
          f"callback (motor, riders, path) {out['closed_loop_3d_callback_share_of_bare']:.3f} of its time")
    return out


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


# --- issue 15: the batch engine ------------------------------------------------------------
def _batch_chunk(args) -> int:
    """Worker: one chunk of rides on the batch engine; returns how many fell."""
    from euc_sim.simulation.batch import simulate_batch
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
    out.update(mujoco_batch_figures(rides, duration))                   # issue 23
    return out


# --- issue 23: MuJoCo batches on threads --------------------------------------------------
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


def mujoco_batch_figures(rides: int = 1000, duration: float = 20.0, chunk: int = 100) -> dict:
    """Aggregate step rate of :func:`euc_sim.simulation.mujoco_batch.simulate_rides` on 1 and 2
    threads (``rides`` rides with effects, in batches of ``chunk``: a ride's records take
    1.3 MB) over the bare single-thread ``mj_step`` rate of the same model, same process."""
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

    def bare(forces=False):
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = ride.stepper.d.qpos, ride.stepper.d.qvel
        if forces:     # the MuJoCo work of the effects: a drag force at G and a rolling moment, held
            d.xfrc_applied[ride.stepper.b_rider, 0] = -2.0
            d.qfrc_applied[ride.stepper.vx] = -1.0
        mujoco.mj_step(m, d, nstep=steps)

    def batch(nthread, part):
        def run():
            nonlocal fell
            for i in range(0, len(part), chunk):
                res = simulate_rides(part[i:i + chunk], nthread=nthread)
                fell += sum(isinstance(r, Exception) for r in res)
        return run

    small = reqs[:min(rides, 20)]       # best of 3, interleaved with the bare loop: load-robust
    t = timed_together({"bare": lambda: [bare() for _ in small], "one": batch(1, small)}, repeat=3)
    t_bare = timed(bare, repeat=3)
    t_forces = timed(lambda: bare(True), repeat=3)
    t_two = timed(batch(2, reqs), repeat=1)
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
    return out


# --- issue 4: identifying h -------------------------------------------------------------------
def bench_identify() -> dict:
    """Identify h on 34 recordings of 30 s at 120 Hz, both models, with curves: s, and vs a direct search."""
    from scipy.optimize import minimize_scalar

    from euc_sim.model import analytic
    from euc_sim.identification.torques import MODELS
    from euc_sim.identification.h_fit import identify_h, residual_poly
    from euc_sim.simulation.mocap import motion_capture
    from euc_sim.model.parameters import TABLE3
    from euc_sim.identification.processing import kinematics
    from euc_sim.simulation.engine import simulate

    runs = [simulate(m, 30.0) for m in ("deceleration", "acceleration", "constant_speed", "stop_and_go")]
    recs = [motion_capture(runs[i % 4], TABLE3, noise="paper", seed=i) for i in range(34)]

    def ours(recordings, n_boot=0):
        polys = {m: [] for m in MODELS}
        for r in recordings:
            kin = kinematics(r, TABLE3)
            for m in MODELS:
                rp = residual_poly(kin, TABLE3, m)
                polys[m].append(rp)
                identify_h([rp], n_boot=n_boot)                   # per recording, curve kept
        return {m: identify_h(polys[m], n_boot=n_boot) for m in MODELS}   # pooled

    def direct(recordings):
        """Reference: analytic torques re-evaluated at every h (curve + bounded search)."""
        fns = {"3dof": (analytic.driving_torque_1, analytic.driving_torque_2),
               "2dof": (analytic.reduced_driving_torque_1, analytic.reduced_driving_torque_2)}
        for r in recordings:
            kin = kinematics(r, TABLE3)
            sl = kin.interior
            for m in MODELS:
                f1, f2 = fns[m]

                def rmse(h):
                    p = TABLE3.replace(h=float(h))
                    d = (f1(p, kin.q, kin.qd, kin.qdd) - f2(p, kin.q, kin.qd, kin.qdd))[sl]
                    return float(np.sqrt(np.mean(d**2)))
                [rmse(h) for h in np.linspace(0.1, 1.5, 71)]
                minimize_scalar(rmse, bounds=(0.1, 1.5), method="bounded")

    ours(recs[:2])                                                # warm caches
    t_ours = timed(lambda: ours(recs))
    t_boot = timed(lambda: ours(recs, n_boot=400), repeat=1)
    sub = recs[:4]
    t_sub = timed(lambda: ours(sub))
    t_direct = timed(lambda: direct(sub), repeat=1)
    out = {"recordings": len(recs), "seconds_each": 30.0, "identify_s": t_ours,
           "identify_with_bootstrap_400_s": t_boot, "direct_search_4_recordings_s": t_direct,
           "ours_4_recordings_s": t_sub}
    out["ratio_direct_vs_ours"] = t_direct / t_sub
    print(f"  34 recordings x 30 s, both models, curves + pooled : {t_ours:6.3f} s (aim < 1 s, one core)")
    print(f"  the same with a 400-replicate block bootstrap      : {t_boot:6.3f} s")
    print(f"  direct search (analytic torques at every h), 4 rec : {t_direct:6.3f} s vs {t_sub:.3f} s: "
          f"ratio {out['ratio_direct_vs_ours']:.1f}x")
    return out


# --- issue 5: diagnosing a recording --------------------------------------------------------
def bench_diagnose() -> dict:
    """Diagnose a 60 s recording at 120 Hz (one core): s, against identifying h on it alone."""
    import warnings

    from euc_sim.simulation import dataset
    from euc_sim.diagnosis import pipeline as diagnosis
    from euc_sim.identification.h_fit import identify_h, residual_poly
    from euc_sim.model.parameters import TABLE3
    from euc_sim.identification.processing import kinematics
    from euc_sim.simulation.maneuvers import make_maneuver

    spec = dataset.RecordingSpec("bench", make_maneuver("stop_and_go", cycles=6), 60.0, 5,
                                 effects=(("aerodynamic_drag", 0.35),), hide_torques=True)
    rec, meta, _ = dataset.simulated_recording(spec)
    meta = {**meta, "maneuver_options": {"cycles": 6}}
    warnings.simplefilter("ignore")

    def full():
        return diagnosis.diagnose(rec, meta=meta, resimulate=True)

    def selection_only():
        return diagnosis.diagnose(rec, meta=meta, resimulate=False)

    def identify_only():
        kin = kinematics(rec, TABLE3)
        return identify_h([residual_poly(kin, TABLE3)], n_boot=0)

    res = selection_only()                                          # warm caches
    t_full = timed(full, repeat=1)
    t_sel = timed(selection_only, repeat=2)
    t_id = timed(identify_only)
    out = {"samples": len(rec), "seconds_recorded": 60.0, "diagnose_s": t_full,
           "diagnose_without_resimulation_s": t_sel, "identify_h_s": t_id,
           "ratio_diagnose_vs_identify": t_sel / t_id,
           "effects_found": [e["name"] for e in res["effects"]]}
    print(f"  60 s at 120 Hz ({len(rec)} samples), found {out['effects_found']}")
    print(f"  diagnose, with re-simulation      : {t_full:6.2f} s (aim < 10 s, one core)")
    print(f"  diagnose, no re-simulation        : {t_sel:6.2f} s")
    print(f"  identify h alone (reference)      : {t_id:6.3f} s; ratio diagnose / identify = "
          f"{out['ratio_diagnose_vs_identify']:.0f}x")
    return out


# --- issue 12: a 60-minute real ride, mass and drivetrain ---------------------------------
def bench_ride_mass() -> dict:
    """A 64-minute real ride (Blitz 4): mass + drivetrain, and the whole ride command without simulation."""
    import warnings
    from pathlib import Path

    from euc_sim.rides.drivetrain_report import analyse
    from euc_sim.rides.logs import read_log
    from euc_sim.rides.spec import read_spec

    root = Path(__file__).resolve().parents[2] / "shared" / "data" / "euc_core"
    log = root / "trips/begode/blitz/4/4.csv"
    if not log.is_file():
        print(f"  {log} absent: skipped")
        return {"skipped": str(log)}
    warnings.simplefilter("ignore")
    spec = read_spec(root / "specs/blitz.csv")
    t_read = timed(lambda: read_log(log, emit_warnings=False), repeat=1)
    t_mass = timed(lambda: analyse(log, spec), repeat=1)

    def whole():
        from euc_sim.cli.ride import run_ride
        return run_ride(log, simulate=False, spec=spec)

    cpu0 = time.process_time()
    t_all = timed(whole, repeat=1)
    cpu_all = time.process_time() - cpu0        # CPU seconds, every thread: the one-core time
    minutes = read_log(log, emit_warnings=False).duration / 60.0
    out = {"ride_minutes": minutes, "read_s": t_read, "mass_drivetrain_s": t_mass,
           "ride_no_simulate_s": t_all, "ratio_mass_vs_read": t_mass / t_read,
           "ride_no_simulate_cpu_s": cpu_all, "ratio_ride_vs_read": t_all / t_read}
    print(f"  {minutes:.0f}-minute ride: read {t_read:.2f} s (the reference); mass + drivetrain "
          f"(200 bootstrap) {t_mass:.2f} s ({t_mass / t_read:.1f}x reading)")
    print(f"  euc-sim ride --no-simulate, everything (3 balance fits x 200 bootstrap too): "
          f"{t_all:.1f} s wall, {cpu_all:.1f} s CPU ({t_all / t_read:.1f}x reading; aim < 20 s, "
          f"one core)")
    return out


# --- issue 22: h's interval over fresh noise, and the rollout second opinion -----------------
def bench_uncertainty() -> dict:
    """One 15 s deceleration: identify with 40 noise replicates and by rollout, vs identify alone."""
    from euc_sim.identification.h_fit import Recording, identify_recordings
    from euc_sim.identification.processing import kinematics
    from euc_sim.identification.rollout_fit import fit_rollout
    from euc_sim.model.parameters import TABLE3
    from euc_sim.simulation.engine import default_rider, simulate
    from euc_sim.simulation.mocap import motion_capture

    run = simulate("deceleration", 15.0, rider=default_rider(TABLE3, noise_std=3.0), seed=1)
    df = motion_capture(run, TABLE3, noise="paper", seed=1)
    rec = Recording("bench", df, {}, TABLE3, kinematics(df, TABLE3))
    t_plain = timed(lambda: identify_recordings([rec], n_boot=400, n_noise=0))
    t_noise = timed(lambda: identify_recordings([rec], n_boot=400, n_noise=40), repeat=1)
    t_roll = timed(lambda: fit_rollout(df, rec.kin, TABLE3, h0=0.6), repeat=1)
    out = {"identify_s": t_plain, "identify_noise_40_s": t_noise, "rollout_s": t_roll,
           "ratio_noise_replicates_vs_identify": t_noise / t_plain,
           "ratio_rollout_vs_identify": t_roll / t_plain}
    print(f"  identify (block bootstrap 400), 15 s, both models : {t_plain:6.3f} s")
    print(f"  + 40 noise replicates                             : {t_noise:6.3f} s "
          f"({out['ratio_noise_replicates_vs_identify']:.1f}x)")
    print(f"  rollout fit (3-DoF, 15 windows)                   : {t_roll:6.3f} s "
          f"({out['ratio_rollout_vs_identify']:.0f}x; aim <= 10 s)")
    return out


# --- issue 21: a 60-minute ride along a logged-like profile ------------------------------
def bench_ride() -> dict:
    """A 60-minute speed profile ridden by simulate_profile (augmented effects, native) vs a bare mj_step loop."""
    import mujoco

    from controllers.rider import RiderRun
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.tracking import simulate_profile
    from euc_sim.simulation.engine import _MujocoStepper

    minutes = 60.0
    t = np.arange(0.0, minutes * 60.0 + 1e-9, 0.1)          # a log's 10 Hz grid
    v = np.clip(6.0 + 4.0 * np.sin(2 * np.pi * t / 300.0) + 2.0 * np.sin(2 * np.pi * t / 47.0 + 1.0)
                + 1.5 * np.sin(2 * np.pi * t / 13.0), 0.0, None)        # stops, 0.9 m/s² at most
    effects = {"aerodynamic_drag": 0.25, "rolling_resistance": 0.012, "road_slope": 0.01}
    simulate_profile(t[:50], v[:50], TABLE3, effects, track_iterations=0)      # compile, warm caches
    spent = {"rider": 0.0}
    commands = RiderRun.commands

    def timed_commands(self, k0, Y):                    # the rider's Python block law, timed
        t0 = time.perf_counter()
        try:
            return commands(self, k0, Y)
        finally:
            spent["rider"] += time.perf_counter() - t0

    RiderRun.commands = timed_commands
    try:
        t0 = time.perf_counter()
        run = simulate_profile(t, v, TABLE3, effects, track_iterations=0)
        t_ride = time.perf_counter() - t0
    finally:
        RiderRun.commands = commands
    if run.falls:
        raise RuntimeError(f"bench ride: the rider fell ({run.falls[0]}); the timing would be of a shorter ride")
    stepper = _MujocoStepper(TABLE3, "ideal", 1e-3, {}, None)
    bare_s = 120.0                                        # seconds of ride stepped bare, scaled
    t0 = time.perf_counter()
    mujoco.mj_step(stepper.m, stepper.d, nstep=int(bare_s / 1e-3))
    t_bare = (time.perf_counter() - t0) * (minutes * 60.0 / bare_s)
    out = {"sixty_minute_seconds": t_ride, "bare_mj_step_sixty_minute_seconds": t_bare,
           "ratio_ride_vs_bare_mj_step": t_ride / t_bare, "rider_law_seconds": spent["rider"],
           "real_time_factor": minutes * 60.0 / t_ride}
    print(f"  60-minute ride, 1 kHz, drag + rolling + slope (native): {t_ride:6.1f} s "
          f"({out['real_time_factor']:.0f}x real time; aim < 60 s, one core)")
    print(f"  bare mj_step loop, same model, 60 min (from {bare_s:.0f} s): {t_bare:6.1f} s "
          f"(ride / bare = {out['ratio_ride_vs_bare_mj_step']:.2f}x)")
    print(f"  of which the rider's block law (Python): {spent['rider']:.1f} s")
    return out


SECTIONS: dict[str, Callable[[], dict]] = {
    "inverse": bench_inverse,
    "closed_loop": bench_closed_loop,
    "dataset": bench_dataset,
    "batch": bench_batch,
    "identify": bench_identify,
    "diagnose": bench_diagnose,
    "ride_mass": bench_ride_mass,
    "spatial": bench_spatial,
    "uncertainty": bench_uncertainty,
    "ride": bench_ride,
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
