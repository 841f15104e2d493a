"""Coverage of h's 95 % interval over independent simulated rides.

Each ride is its own draw of everything that varies between real rides: the
maneuver's speeds and timing (:func:`draw_maneuver`), the rider's motor noise (and
so the trajectory) and the measurement noise, all from the ride's seed.  The ride is
identified exactly as ``euc-sim identify`` does (:func:`~euc_sim.identification.h_fit.identify_recordings`),
and its interval is scored against the truth: h = 0.6 m for the 3-DoF model, and for
the reduced model, whose h is biased by the reduction itself, the h it returns on the
same ride without measurement noise (its pseudo-true value).

:func:`one_ride` is a module-level function of one picklable argument, for
:func:`euc_sim.simulation.runner.run_tasks` (process pool or Dask).
"""

from __future__ import annotations

import math
import time

import numpy as np

from euc_sim.model.parameters import TABLE3
from euc_sim.simulation.maneuvers import Maneuver, make_maneuver

#: Maneuver kinds of the study; ``speed_changes`` is a random sequence of speed ramps.
KINDS = ("deceleration", "acceleration", "stop_and_go", "speed_changes")
#: Seed offset per kind, so that rides of different kinds never share a seed.
KIND_OFFSET = {k: 1_000_000 * (i + 1) for i, k in enumerate(KINDS)}
#: Largest mean acceleration of a ``speed_changes`` ramp, m/s² (steeper ones made
#: the simulated rider fall: 2 of 25 rides at up to 2.7 m/s²).
MAX_RAMP_ACCEL = 1.2


def draw_maneuver(kind: str, rng: np.random.Generator, duration: float = 15.0) -> Maneuver:
    """A maneuver of ``kind`` with speeds and timing drawn from ``rng`` (m/s, s).

    deceleration and acceleration: the ranges of ``euc-sim dataset``; stop_and_go:
    top speed 2-3 m/s, ramps of 2.5-3.5 s, holds of 1-2.5 s; speed_changes: from
    1-3 m/s, steps of 0.7-2 m/s up or down (kept within 0.5-4.5 m/s) over ramps of
    1.5-3 s (longer where the mean acceleration would exceed :data:`MAX_RAMP_ACCEL`),
    0.5-2 s apart, as many as fit in ``duration``.

    Raises
    ------
    ValueError
        for an unknown kind.
    """
    u = rng.uniform
    if kind == "deceleration":
        return make_maneuver(kind, v0=u(3.0, 4.5), v1=u(0.3, 1.0), start=u(2.0, 4.0), ramp=u(3.0, 5.0))
    if kind == "acceleration":
        return make_maneuver(kind, v0=u(0.5, 1.5), v1=u(3.0, 4.5), start=u(2.0, 4.0), ramp=u(3.0, 5.0))
    if kind == "stop_and_go":
        return make_maneuver(kind, v=u(2.0, 3.0), start=u(0.5, 1.5), ramp=u(2.5, 3.5),
                             hold=u(1.0, 2.5), cycles=3)
    if kind == "speed_changes":
        v = v0 = u(1.0, 3.0)
        ramps, t = [], u(1.0, 2.0)
        while True:
            step = rng.choice([-1.0, 1.0]) * u(0.7, 2.0)
            if not 0.5 <= v + step <= 4.5:         # turn back at the speed limits
                step = -step
            target = float(np.clip(v + step, 0.5, 4.5))
            dur = max(u(1.5, 3.0), abs(target - v) / MAX_RAMP_ACCEL)
            if t + dur > duration - 1.0:
                break
            ramps.append((float(t), float(dur), target))
            v, t = target, t + dur + u(0.5, 2.0)
        return Maneuver("profile", float(v0), tuple(ramps))
    raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")


def ride_seed(kind: str, index: int, first_seed: int = 0) -> int:
    """The seed of ride ``index`` of ``kind``: maneuver, rider noise and measurement noise."""
    return KIND_OFFSET[kind] + int(first_seed) + int(index)


def one_ride(arg: tuple) -> dict:
    """Simulate, record and identify one ride; score its intervals.

    Parameters
    ----------
    arg : (kind, seed, duration, n_boot, n_noise[, rollout])
        ``rollout`` true adds the 3-DoF rollout fit
        (:func:`euc_sim.identification.rollout_fit.fit_rollout`) as ``3dof.rollout``.

    Returns
    -------
    dict
        Per model: ``h``, ``truth``, ``ci`` (the reported interval), ``ci_block``
        (the block bootstrap's alone), ``noise_sd``, ``noise_bias``, ``identifiable``;
        and ``seconds`` (identification only) and the maneuver.
    """
    from euc_sim.identification.h_fit import Recording, identify_recordings
    from euc_sim.identification.processing import DEFAULT_SMOOTHING, kinematics
    from euc_sim.simulation.engine import default_rider, simulate
    from euc_sim.simulation.mocap import motion_capture

    kind, seed, duration, n_boot, n_noise, *more = arg
    rng = np.random.default_rng([int(seed), 22])
    man = draw_maneuver(kind, rng, duration)
    run = simulate(man, duration, params=TABLE3, rider=default_rider(TABLE3, noise_std=3.0), seed=seed)

    def rec(noise):
        df = motion_capture(run, TABLE3, noise=noise, seed=seed)
        return Recording(name=f"{kind}-{seed}", df=df, meta={}, params=TABLE3,
                         kin=kinematics(df, TABLE3, DEFAULT_SMOOTHING))

    clean = identify_recordings([rec("none")], n_boot=0, n_noise=0)["pooled"]
    t0 = time.perf_counter()
    fits = identify_recordings([rec("paper")], n_boot=n_boot, n_noise=n_noise, seed=seed)["pooled"]
    out = {"kind": kind, "seed": int(seed), "seconds": time.perf_counter() - t0,
           "maneuver": man.as_dict()}
    for m, f in fits.items():
        out[m] = {"h": f.h, "truth": TABLE3.h if m == "3dof" else clean[m].h,
                  "ci": list(f.h_ci95), "ci_block": list(f.h_ci95_block),
                  "noise_sd": f.noise_sd, "noise_bias": f.noise_bias,
                  "identifiable": bool(f.identifiable)}
    if more and more[0]:
        from euc_sim.identification.rollout_fit import fit_rollout

        r = rec("paper")
        rf = fit_rollout(r.df, r.kin, TABLE3, h0=fits["3dof"].h)
        out["3dof"]["rollout"] = {"h": rf.h, "ci": list(rf.h_ci95), "seconds": rf.seconds,
                                  "at_bound": rf.at_bound}
    return out


def summarize(rows: list[dict], models=("3dof", "2dof")) -> dict:
    """Coverage and error per kind and model.

    Returns
    -------
    dict
        ``{kind: {model: {"rides", "coverage", "coverage_block", "mean_error_mm",
        "sd_error_mm", "mean_width_mm", "identifiable"}}}``; errors against each
        model's truth (:func:`one_ride`).
    """
    out: dict = {}
    for kind in sorted({r["kind"] for r in rows}, key=lambda k: KINDS.index(k) if k in KINDS else 99):
        rs = [r for r in rows if r["kind"] == kind]
        out[kind] = {}
        for m in models:
            h = np.array([r[m]["h"] for r in rs])
            tr = np.array([r[m]["truth"] for r in rs])
            ci = np.array([r[m]["ci"] for r in rs])
            cb = np.array([r[m]["ci_block"] for r in rs])
            err = h - tr
            out[kind][m] = {
                "rides": len(rs),
                "coverage": float(np.mean((ci[:, 0] <= tr) & (tr <= ci[:, 1]))),
                "coverage_block": float(np.mean((cb[:, 0] <= tr) & (tr <= cb[:, 1]))),
                "mean_error_mm": 1e3 * float(err.mean()),
                "sd_error_mm": 1e3 * float(err.std(ddof=1)) if len(rs) > 1 else math.nan,
                "mean_width_mm": 1e3 * float(np.mean(ci[:, 1] - ci[:, 0])),
                "identifiable": float(np.mean([r[m]["identifiable"] for r in rs])),
            }
            ro = [r[m]["rollout"] for r in rs if "rollout" in r[m]]
            if ro:
                sel = [r for r in rs if "rollout" in r[m]]
                rh = np.array([x["h"] for x in ro])
                rci = np.array([x["ci"] for x in ro])
                eh = np.array([r[m]["h"] for r in sel])
                eci = np.array([r[m]["ci"] for r in sel])
                rtr = np.array([r[m]["truth"] for r in sel])
                out[kind][m]["rollout"] = {
                    "rides": len(ro),
                    "coverage": float(np.mean((rci[:, 0] <= rtr) & (rtr <= rci[:, 1]))),
                    "mean_error_mm": 1e3 * float(np.mean(rh - rtr)),
                    "sd_error_mm": 1e3 * float(np.std(rh - rtr, ddof=1)) if len(ro) > 1 else math.nan,
                    "intervals_overlap": float(np.mean((rci[:, 0] <= eci[:, 1]) & (eci[:, 0] <= rci[:, 1]))),
                    "each_in_the_others": float(np.mean((rci[:, 0] <= eh) & (eh <= rci[:, 1])
                                                        & (eci[:, 0] <= rh) & (rh <= eci[:, 1]))),
                    "seconds_median": float(np.median([x["seconds"] for x in ro])),
                }
    return out
