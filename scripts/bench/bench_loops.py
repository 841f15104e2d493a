"""Benchmarks of the model's step and the per-ride closed loops (``scripts/bench.py`` sections
``inverse``, ``closed_loop``, ``spatial``)."""

from __future__ import annotations

import numpy as np

from bench_timing import timed, timed_together


# --- vectorised analytic inverse dynamics ---------------------------------------
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


# --- closed-loop simulation -------------------------------------------------------
def bench_closed_loop() -> dict:
    """Closed-loop real-time factor at 1 kHz on one core vs bare mj_step loops.

    The closed loop is :func:`simulate`'s default, the native loop (the motor PD a numba
    MuJoCo control callback); the Python loop (``native=False``) beside it.

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
    out["closed_loop_cost_vs_bare_step"] = t_loop / t_bare          # native loop
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


# --- the spatial closed loop ----------------------------------------------------
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
    # the native loop, the bare step and a 10-step ride (per-ride setup) interleaved
    together = timed_together({"bare": bare, "loop": lambda: simulate_3d("figure_eight", duration, seed=1),
                               "setup": lambda: simulate_3d("figure_eight", 0.01, seed=1)})
    t_bare, t_loop, t_setup = together["bare"], together["loop"], together["setup"]
    t_py = timed(lambda: simulate_3d("figure_eight", duration, seed=1, native=False), repeat=2)
    out = {"bare_mj_step_3d_real_time_factor": duration / t_bare,
           "closed_loop_3d_real_time_factor": duration / t_loop,
           "closed_loop_3d_python_real_time_factor": duration / t_py}
    out["closed_loop_3d_cost_vs_bare_step"] = t_loop / t_bare          # native loop
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
