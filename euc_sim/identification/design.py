"""Experiment design: which maneuvers identify h, and how many recordings of each.

Monte Carlo: R rides of each maneuver (one MuJoCo batch, rider noise seeded per ride),
sampled like motion capture at each noise level and fitted as the paper does (3-DoF,
:func:`euc_sim.identification.h_fit.identify_h`); ``h_sd`` is the spread of the R estimates.
Fisher: linearised at the true h, ĥ − h ≈ −Σ s_k e_k / Σ s_k², s = ∂r/∂h, so
var ĥ = sᵀ C s / (sᵀ s)², C the residual's autocovariance (Bartlett-tapered to
:data:`FISHER_MAX_LAG`); ``h_sd_fisher`` its square root.  Recordings for a target σ*:
n = ⌈(h_sd/σ*)²⌉; a maneuver needing :data:`FLAT_FACTOR` times the best one's is *flat*.
Maneuver i of run seed S draws from ``SeedSequence(S).spawn(M)[i]``.
"""

from __future__ import annotations

import math
import textwrap
import warnings
from typing import Sequence

import numpy as np

from euc_sim.errors import InputError
from euc_sim.identification.h_fit import identify_h, residual_poly
from euc_sim.identification.processing import DEFAULT_SMOOTHING, kinematics
from euc_sim.model.parameters import Params, TABLE3
from euc_sim.simulation.engine import default_rider
from euc_sim.simulation.errors import FallError
from euc_sim.simulation.maneuvers import make_maneuver
from euc_sim.simulation.mocap import NOISE_LEVELS, motion_capture

__all__ = ["DESIGN_MANEUVERS", "FLAT_FACTOR", "FISHER_MAX_LAG", "maneuver_study", "design",
           "recommendation", "design_figure"]

#: Maneuvers the design can simulate (the built-in ones; a profile needs a file).
DESIGN_MANEUVERS = ("constant_speed", "acceleration", "deceleration", "stop_and_go")
#: A maneuver needing this many times the recordings of the best one is flat.
FLAT_FACTOR = 10.0
#: Longest lag of the residual's autocovariance in the Fisher prediction, s.
FISHER_MAX_LAG = 1.0
#: Search interval of h, m (as ``euc-sim identify``).
H_BOUNDS = (0.1, 1.5)


def _sensitivity(poly, h: float) -> np.ndarray:
    """∂r/∂h at h of r = P(h)/D(h), N·m per m."""
    P, D = poly.P, poly.D
    num = P[0] + h * (P[1] + h * P[2])
    den = D[0] + h * D[1]
    return ((P[1] + 2.0 * h * P[2]) * den - num * D[1]) / den**2


def _autocovariance(e: np.ndarray, max_lag: int) -> np.ndarray:
    """Biased autocovariance of the rows of e (pooled), lags 0..max_lag, Bartlett-tapered."""
    from scipy.signal import correlate

    n = e.shape[1]
    acov = np.mean([correlate(row, row, mode="full", method="fft")[n - 1:n + max_lag] / n for row in e], axis=0)
    return acov * (1.0 - np.arange(max_lag + 1) / (max_lag + 1))


def _sandwich_variance(s: np.ndarray, acov: np.ndarray) -> float:
    """sᵀ C s / (sᵀ s)² with C Toeplitz from ``acov`` (lags 0..L), m²."""
    from scipy.signal import correlate

    n, L = s.size, acov.size - 1
    rs = correlate(s, s, mode="full", method="fft")[n - 1:n + L]        # Σ_k s_k s_{k+τ}
    quad = acov[0] * rs[0] + 2.0 * float(np.dot(acov[1:], rs[1:]))
    return quad / rs[0] ** 2


def _fit(rec, p: Params):
    kin = kinematics(rec, p, DEFAULT_SMOOTHING)
    poly = residual_poly(kin, p, "3dof")
    return poly, identify_h([poly], bounds=H_BOUNDS, n_boot=0)


def maneuver_study(args) -> dict:
    """One maneuver task of :func:`design` (``(maneuver, rides, duration, noise_scales, (seed, index), params,
    rider_noise)``).

    Returns ``h`` (scales × rides, m), ``fisher_var`` (scales, m²), ``identifiable``, ``h_grid``
    and ``rmse_rel`` (the mean RMSE(h) curve over its minimum, scales × grid) and ``fell``.
    """
    from euc_sim.simulation.mujoco_batch import simulate_rides  # deferred: loads scipy.linalg, mujoco (0.4 s)

    name, rides, duration, scales, (seed, index), p, rider_noise = args
    states = [c.generate_state(2) for c in np.random.SeedSequence(seed, spawn_key=(index,)).spawn(rides)]
    seeds, sensor_seeds = [int(s[0]) for s in states], [int(s[1]) for s in states]
    rider = default_rider(p, noise_std=rider_noise)
    runs = simulate_rides([{"maneuver": make_maneuver(name), "duration": duration, "seed": s, "params": p,
                            "rider": rider} for s in seeds], nthread=1)    # one MuJoCo batch
    ok = [r for r in range(rides) if not isinstance(runs[r], FallError)]
    sig_pos, sig_ang = NOISE_LEVELS["paper"]
    out = {"h": [], "fisher_var": [], "identifiable": [], "rmse_rel": [], "fell": rides - len(ok)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean = {r: _fit(motion_capture(runs[r], p, noise="none"), p)[0] for r in ok}
        for scale in scales:
            hs, idents, curves, errors = [], [], [], []
            for r in ok:
                rec = motion_capture(runs[r], p, noise=(scale * sig_pos, scale * sig_ang), seed=sensor_seeds[r])
                poly, fit = _fit(rec, p)
                hs.append(fit.h)
                idents.append(bool(fit.identifiable))
                curves.append(fit.rmse_grid / fit.rmse)
                errors.append(poly.residual(p.h) - clean[r].residual(p.h))
                out["h_grid"] = fit.h_grid
            lag = int(round(FISHER_MAX_LAG / float(np.median(np.diff(clean[ok[0]].t)))))
            acov = _autocovariance(np.array(errors), lag)
            var = [_sandwich_variance(_sensitivity(clean[r], p.h), acov) for r in ok]
            out["h"].append(hs)
            out["identifiable"].append(idents)
            out["rmse_rel"].append(np.mean(curves, axis=0))
            out["fisher_var"].append(float(np.mean(var)))
    return {k: (np.asarray(v) if k not in ("fell", "h_grid") else v) for k, v in out.items()}


def recordings_needed(sd: float, target: float) -> int:
    """Recordings that pool an estimate of spread ``sd`` to ``target`` (same unit): n = ⌈(sd/target)²⌉, at least 1."""
    return max(1, int(math.ceil((sd / target) ** 2)))


def recordings_for(h_sd: float, targets: Sequence[float]) -> dict:
    """``{"σ*": n}``: recordings of one maneuver that pool to σ* m (:func:`recordings_needed`)."""
    return {f"{t:g}": recordings_needed(h_sd, t) for t in targets}


def design(maneuvers: Sequence[str], *, rides: int = 40, duration: float = 15.0,
           noise_scales: Sequence[float] = (0.5, 1.0, 2.0), targets: Sequence[float] = (0.05, 0.02, 0.01),
           seed: int = 0, params: Params = TABLE3, rider_noise: float = 3.0,
           scheduler: str | None = None, workers: int | None = None, progress: bool = True) -> dict:
    """How precisely each maneuver identifies h, by Monte Carlo and Fisher information.

    Parameters
    ----------
    maneuvers : sequence of str
        Names of :data:`DESIGN_MANEUVERS`.
    rides : int
        Monte Carlo rides per maneuver (at least 3).
    duration : float
        Length of each recording, s.
    noise_scales : sequence of float
        Sensor noise as multiples of the paper's (0.2 mm, 0.5°); must include 1.0.
    targets : sequence of float
        Target standard deviations of h, m.
    seed : int
    params : Params
    rider_noise : float
        Rider motor noise, N·m.
    scheduler, workers, progress
        See :func:`euc_sim.simulation.runner.run_tasks`.

    Returns
    -------
    dict
        CONTRACT's ``euc-sim design`` JSON plus ``curves`` for the figure.
    """
    from euc_sim.simulation.runner import run_tasks  # deferred: loads multiprocessing, tqdm (0.03 s)

    _check(maneuvers, rides, duration, noise_scales, targets)
    tasks = [(m, (m, rides, float(duration), tuple(noise_scales), (int(seed), i), params, rider_noise))
             for i, m in enumerate(maneuvers)]
    rep = run_tasks(maneuver_study, tasks, scheduler=scheduler, workers=workers, progress=progress,
                    desc="design")
    if rep.failed:
        raise InputError("design: maneuvers failed: " + "; ".join(f"{n}: {r}" for n, r in rep.failed.items()))
    i_ref = list(noise_scales).index(1.0)
    rows, curves = [], {}
    for m in maneuvers:
        res = rep.results[m]
        if len(res["h"][0]) < 3:
            raise InputError(f"design: maneuver {m}: {res['fell']} of {rides} rides fell, too few left")
        by_noise = [{"noise_scale": float(s), "h_sd": float(np.std(res["h"][j], ddof=1)),
                     "h_sd_fisher": float(math.sqrt(res["fisher_var"][j])),
                     "h_bias": float(np.mean(res["h"][j]) - params.h),
                     "identifiable_fraction": float(np.mean(res["identifiable"][j]))}
                    for j, s in enumerate(noise_scales)]
        ref = by_noise[i_ref]
        rows.append({"maneuver": m, "h_sd": ref["h_sd"], "h_sd_fisher": ref["h_sd_fisher"],
                     "h_bias": ref["h_bias"], "identifiable_fraction": ref["identifiable_fraction"],
                     "recordings_for": recordings_for(ref["h_sd"], targets), "rides": len(res["h"][0]),
                     "fell": res["fell"], "by_noise": by_noise})
        curves[m] = {"h_grid": res["h_grid"], "rmse_rel": res["rmse_rel"]}
    best = min(rows, key=lambda r: r["h_sd"])
    flat = [r["maneuver"] for r in rows if (r["h_sd"] / best["h_sd"]) ** 2 >= FLAT_FACTOR]
    out = {"maneuvers": rows, "h_true": params.h, "rides": rides, "duration": float(duration),
           "noise": {"position_m": NOISE_LEVELS["paper"][0], "angle_rad": NOISE_LEVELS["paper"][1],
                     "scales": [float(s) for s in noise_scales]},
           "rider_noise": rider_noise, "seed": int(seed), "targets": [float(t) for t in targets],
           "flat": flat, "best": best["maneuver"]}
    out["recommendation"] = recommendation(out)
    out["curves"] = curves
    return out


def check_maneuvers(maneuvers: Sequence[str]) -> None:
    """InputError (naming ``--maneuvers``) unless every maneuver is one of :data:`DESIGN_MANEUVERS`."""
    bad = [m for m in maneuvers if m not in DESIGN_MANEUVERS]
    if not maneuvers or bad:
        raise InputError(f"--maneuvers: unknown {', '.join(bad) or '(none given)'}; "
                         f"valid: {', '.join(DESIGN_MANEUVERS)}")


def check_rides(rides, duration: float, option: str) -> None:
    """InputError unless ``rides`` (naming ``option``) is an integer of at least 3 and ``duration`` (s) at least 5."""
    if not (isinstance(rides, int) and rides >= 3):
        raise InputError(f"{option} must be an integer of at least 3, got {rides!r}")
    if not (math.isfinite(duration) and duration >= 5.0):
        raise InputError(f"--duration must be at least 5 s (the fit's filters need it), got {duration!r}")


def _check(maneuvers, rides, duration, noise_scales, targets) -> None:
    check_maneuvers(maneuvers)
    if len(set(maneuvers)) != len(maneuvers):
        raise InputError(f"--maneuvers: a maneuver is listed twice in {','.join(maneuvers)}")
    check_rides(rides, duration, "--rides")
    if not all(math.isfinite(s) and 0 < s <= 100 for s in noise_scales) or 1.0 not in noise_scales:
        raise InputError(f"--noise-scales must lie in (0, 100] and include 1 (the paper's noise), "
                         f"got {list(noise_scales)}")
    if not targets or not all(math.isfinite(t) and 0 < t <= 1 for t in targets):
        raise InputError(f"--targets must be standard deviations in (0, 1] m, got {list(targets)}")


def recommendation(result: dict) -> str:
    """One paragraph for people: which maneuvers are flat and what to record instead."""
    rows = {r["maneuver"]: r for r in result["maneuvers"]}
    best = rows[result["best"]]
    tight = min(result["targets"])
    lines = []
    for m in result["flat"]:
        r = rows[m]
        lines.append(f"{m} is flat in h: one recording gives ±{r['h_sd'] * 1000:.1f} mm (1 sd), "
                     f"{(r['h_sd'] / best['h_sd']) ** 2:.0f}x the recordings of {best['maneuver']} for "
                     f"the same precision.")
    lines.append(f"Record {best['maneuver']}: {best['recordings_for'][f'{tight:g}']} recording(s) of "
                 f"{result['duration']:g} s reach ±{tight * 1000:g} mm (one gives ±{best['h_sd'] * 1000:.1f} mm).")
    return " ".join(lines)


def design_figure(result: dict):
    """The RMSE(h) curves (the paper's Fig. 8) per noise scale and h's sd across scales (Monte Carlo and Fisher),
    one colour per maneuver."""
    from matplotlib import rcParamsDefault
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from euc_sim.identification.plots import plain_log_ticks  # deferred: loads matplotlib (0.3 s)

    scales = result["noise"]["scales"]
    fig = Figure(figsize=(max(4.4 * len(scales), 9.0), 8.2), layout="constrained")
    axes = fig.subplots(2, len(scales), squeeze=False)
    colors = rcParamsDefault["axes.prop_cycle"].by_key()["color"]
    for j, s in enumerate(scales):
        ax = axes[0, j]
        for i, row in enumerate(result["maneuvers"]):
            c = result["curves"][row["maneuver"]]
            ax.plot(c["h_grid"], c["rmse_rel"][j], color=colors[i % len(colors)])
        ax.axvline(result["h_true"], color="k", lw=0.8, ls=":")
        ax.set(title=f"sensor noise {s:g}x paper", xlabel="h (m)", ylabel="RMSE(M_d,1 - M_d,2) / minimum",
               ylim=(0.95, None))
    ax = axes[1, 0]
    for i, row in enumerate(result["maneuvers"]):
        col = colors[i % len(colors)]
        ax.plot(scales, [b["h_sd"] * 1000 for b in row["by_noise"]], "o", color=col, ms=6, zorder=3)
        ax.plot(scales, [b["h_sd_fisher"] * 1000 for b in row["by_noise"]], "--", color=col, zorder=2)
    ax.set(xscale="log", yscale="log", xlabel="sensor noise (x paper: 0.2 mm, 0.5 deg)",
           ylabel="sd of h from one recording (mm)",
           title=f"h from one {result['duration']:g} s recording ({result['rides']} rides)")
    plain_log_ticks(ax.xaxis, scales)
    plain_log_ticks(ax.yaxis)
    for j in range(1, len(scales)):
        axes[1, j].axis("off")
    if len(scales) > 1:
        text = "\n".join(f"{r['maneuver']}: {r['h_sd'] * 1000:.1f} mm (MC), {r['h_sd_fisher'] * 1000:.1f} mm "
                         f"(Fisher); n for ±10 mm: {recordings_for(r['h_sd'], [0.01])['0.01']}"
                         for r in result["maneuvers"])
        axes[1, 1].text(0.0, 0.95, "At the paper's noise:\n" + text + "\n\n" + textwrap.fill(result["recommendation"], 70),
                        va="top", fontsize=8, transform=axes[1, 1].transAxes)
    handles = [Line2D([], [], color=colors[i % len(colors)], label=r["maneuver"])
               for i, r in enumerate(result["maneuvers"])]
    handles += [Line2D([], [], color="k", ls=":", lw=0.8, label=f"true h = {result['h_true']:g} m"),
                Line2D([], [], color="0.4", ls="", marker="o", label="sd of h: Monte Carlo"),
                Line2D([], [], color="0.4", ls="--", label="sd of h: Fisher prediction")]
    fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 4), fontsize=8)
    fig.suptitle("Experiment design: how precisely each maneuver identifies h")
    return fig
