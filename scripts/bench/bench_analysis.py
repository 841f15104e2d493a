"""Benchmarks of identification and diagnosis (``scripts/bench.py`` sections ``identify``,
``diagnose``, ``uncertainty``)."""

from __future__ import annotations

import numpy as np

from bench_timing import timed


# --- identifying h -------------------------------------------------------------------
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


# --- diagnosing a recording --------------------------------------------------------
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


# --- h's interval over fresh noise, and the rollout second opinion -----------------
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
