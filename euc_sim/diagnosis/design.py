"""Experiment design for the catalog effects: how precisely each maneuver measures each one.

For each maneuver and effect, R recordings are simulated with the effect at
:func:`nominal_magnitude` and the paper's sensor noise, and fitted as the
diagnosis would (nominal model plus that effect's term, jointly with h): ``sd`` is the
spread of the R estimates, ``bias`` their mean minus the truth, ``sd_cov`` the root mean of
the predicted variances (the diagnosis's cluster covariance).  Recordings needed:
n = ⌈(sd / (f·|a|))²⌉ for a target sd of a fraction f of the magnitude a, and
n = ⌈(min_t·sd / |a|)²⌉ to name it.  Task (maneuver i, effect j) of run seed S draws from
``SeedSequence(S, spawn_key=(1, i, j))``.  :mod:`euc_sim.identification.design` does the same for h.
"""

from __future__ import annotations

import math
import warnings
from typing import Sequence

import numpy as np

from euc_sim.diagnosis.candidates import build_problem, visibility
from euc_sim.diagnosis.common import THRESHOLDS, plausible_range
from euc_sim.diagnosis.estimates import estimate_of, sub_cov
from euc_sim.diagnosis.prepare import prepare
from euc_sim.errors import InputError
from euc_sim.identification import regression as reg
from euc_sim.identification.design import check_maneuvers, check_rides, recordings_needed
from euc_sim.model.parameters import Params, TABLE3
from euc_sim.simulation import effects as fx
from euc_sim.simulation.dataset import RecordingSpec, simulated_recordings
from euc_sim.simulation.engine import default_rider, true_params
from euc_sim.simulation.errors import FallError
from euc_sim.simulation.maneuvers import make_maneuver
from euc_sim.simulation.mocap import NOISE_LEVELS
from euc_sim.simulation.runner import run_tasks

__all__ = ["nominal_magnitude", "effect_estimate", "effect_study", "effects_design", "effects_design_figure",
           "RELATIVE_TARGETS", "parse_effects"]

#: Target standard deviations as fractions of the effect's magnitude.
RELATIVE_TARGETS = (0.25, 0.1)
#: Columns of a recording with (without) the torques, for the visibility rules.
_COLUMNS = ("t", "x", "gamma", "phi")
#: The design's maneuvers are planar: the lateral effect's tilt and yaw come from its
#: own slalom (:func:`euc_sim.simulation.maneuvers.lateral_profile`) and are recorded.
_LATERAL_COLUMNS = ("psi", "theta")


def nominal_magnitude(name: str, params: Params = TABLE3) -> float:
    """The effect's Monte Carlo value, CONTRACT unit: the geometric middle of its plausible range (``rider_mass``:
    the nominal mass plus it, kg)."""
    lo, hi = plausible_range(name)
    mid = math.sqrt(lo * hi)
    return fx.RECORDS.absent_value(name, params) + mid


def parse_effects(text: str) -> list[str]:
    """``"all"`` or comma-separated CONTRACT effect names → the list, checked (naming ``--effect``)."""
    names = list(fx.CATALOG) if text.strip() == "all" else [e.strip() for e in text.split(",") if e.strip()]
    bad = [e for e in names if e not in fx.CATALOG]
    if not names or bad:
        raise InputError(f"--effect: unknown {', '.join(bad) or '(none given)'}; "
                         f"valid: all, {', '.join(fx.CATALOG)}")
    if len(set(names)) != len(names):
        raise InputError(f"--effect: an effect is listed twice in {text}")
    return names


def effect_estimate(recording, meta: dict, name: str, params: Params, h0: float) -> tuple[float, float]:
    """The diagnosis's estimate of one effect on one recording and its standard error, in the effect's unit.

    ``h0`` (m): the h at which the candidate columns are built.  ValueError when the
    recording cannot reveal the effect.
    """
    prep = prepare(recording, params=params, meta=meta)
    problem, info = build_problem(prep, h0)
    if name not in problem.candidates:
        raise InputError(f"effect {name!r}: not a candidate of this recording "
                         f"(candidates: {', '.join(problem.candidates)})")
    fit = reg.fit_set(problem, (name,))
    cov, dof = reg.covariance(problem, fit)
    est, _, se = estimate_of(info[name], fit.theta[name], sub_cov(problem, (name,), cov, name), dof)
    return float(est), float(se)


def effect_study(args) -> dict:
    """One (maneuver, effect) task of :func:`effects_design`: ``estimates`` and ``se`` per ride that did not fall,
    and ``fell``."""
    name, effect, value, rides, duration, (seed, i, j), p, rider_noise, with_torques = args
    seeds = [int(c.generate_state(1)[0])
             for c in np.random.SeedSequence(seed, spawn_key=(1, i, j)).spawn(rides)]
    rider = default_rider(true_params(p, {effect: value}), noise_std=rider_noise)   # he knows his weight
    specs = [RecordingSpec(f"{name}-{effect}-{s}", make_maneuver(name), duration, s, params=p,
                           effects=((effect, value),), noise=NOISE_LEVELS["paper"],
                           hide_torques=not with_torques, rider=rider) for s in seeds]
    est, ses, fell = [], [], 0
    for made in simulated_recordings(specs):        # the R rides as one MuJoCo batch
        if isinstance(made, FallError):
            fell += 1
            continue
        rec, meta, _ = made
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            e, se = effect_estimate(rec, meta, effect, p, p.h)
        est.append(e)
        ses.append(se)
    return {"estimates": est, "se": ses, "fell": fell}


def effects_design(maneuvers: Sequence[str], effect_names: Sequence[str], *, rides: int = 10,
                   duration: float = 15.0, seed: int = 0,
                   params: Params = TABLE3, rider_noise: float = 3.0, with_torques: bool = False,
                   scheduler: str | None = None, workers: int | None = None,
                   progress: bool = True) -> dict:
    """How precisely each maneuver measures each catalog effect, by Monte Carlo and covariance.

    Parameters
    ----------
    maneuvers : sequence of str
        Names of :data:`euc_sim.identification.design.DESIGN_MANEUVERS`.
    effect_names : sequence of str
    rides : int
        Recordings per (maneuver, effect), at least 3.
    duration : float
        Length of each recording, s.
    seed : int
    params : Params
        Nominal parameters (h: the truth).
    rider_noise : float
        Rider motor noise, N·m.
    with_torques : bool
        Record M_d and M_h (rider mass and bearing friction become visible).
    scheduler, workers, progress
        See :func:`euc_sim.simulation.runner.run_tasks`.

    Returns
    -------
    dict
        ``effects`` (per effect: ``nominal``, ``magnitude``, ``unit``, ``visible``, ``reason``),
        ``by_maneuver`` (maneuver → effect → ``sd``, ``sd_cov``, ``bias``, ``recordings_for``,
        ``recordings_to_detect``, ``rides``, ``fell``), ``best`` and the settings.
    """
    _check(maneuvers, effect_names, rides, duration)
    cols = _COLUMNS + (("M_d", "M_h") if with_torques else ())
    table = {}
    for e in effect_names:
        vis = visibility(cols + (_LATERAL_COLUMNS if e == "lateral_dynamics" else ()))[e]
        value = nominal_magnitude(e, params)
        table[e] = {"nominal": value, "magnitude": abs(value - fx.RECORDS.absent_value(e, params)),
                    "unit": fx.get(e).unit, "visible": vis["visible"], "reason": vis["reason"]}
    tasks = [(f"{m}/{e}", (m, e, table[e]["nominal"], rides, float(duration),
                           (int(seed), i, j), params, rider_noise, bool(with_torques)))
             for i, m in enumerate(maneuvers) for j, e in enumerate(effect_names) if table[e]["visible"]]
    rep = run_tasks(effect_study, tasks, scheduler=scheduler, workers=workers, progress=progress,
                    desc="design effects")
    by_maneuver = {m: {} for m in maneuvers}
    for key, res in rep.results.items():
        m, e = key.split("/")
        by_maneuver[m][e] = _summary(res, table[e], e, rides)
    for key, why in rep.failed.items():
        m, e = key.split("/")
        by_maneuver[m][e] = {"failed": str(why)}
    best = {}
    for e in effect_names:
        scored = [(by_maneuver[m][e]["sd"], m) for m in maneuvers
                  if by_maneuver[m].get(e, {}).get("sd") is not None]
        if scored:
            best[e] = min(scored)[1]
    return {"effects": table, "by_maneuver": by_maneuver, "best": best, "rides": rides,
            "duration": float(duration), "noise_scale": 1.0, "with_torques": bool(with_torques),
            "min_t": THRESHOLDS.min_t, "relative_targets": list(RELATIVE_TARGETS), "seed": int(seed)}


def _summary(res: dict, entry: dict, effect: str, rides: int) -> dict:
    """One (maneuver, effect) cell of the design from its Monte Carlo."""
    est, se = np.asarray(res["estimates"], float), np.asarray(res["se"], float)
    out = {"rides": int(est.size), "fell": int(res["fell"])}
    if est.size < 3:
        out.update({"sd": None, "sd_cov": None, "bias": None,
                    "why": f"{res['fell']} of {rides} rides fell, too few left"})
        return out
    sd = float(np.std(est, ddof=1))
    a = entry["magnitude"]
    out.update({"sd": sd, "sd_cov": float(np.sqrt(np.mean(se ** 2))), "bias": float(np.mean(est) - entry["nominal"]),
                "recordings_for": {f"{f:g}": recordings_needed(sd, f * a) for f in RELATIVE_TARGETS},
                "recordings_to_detect": recordings_needed(sd, 1.0 / THRESHOLDS.min_t * a)})
    return out


def _check(maneuvers, effect_names, rides, duration) -> None:
    check_maneuvers(maneuvers)
    parse_effects(",".join(effect_names))
    check_rides(rides, duration, "--effect-rides")


def effects_design_figure(result: dict):
    """Each effect's sd relative to its magnitude per maneuver: Monte Carlo (bars), covariance (markers), the
    detection line 1/min_t."""
    from matplotlib import rcParamsDefault
    from matplotlib.figure import Figure

    from euc_sim.identification.plots import plain_log_ticks  # deferred: loads matplotlib (0.3 s)

    names = [e for e, v in result["effects"].items() if v["visible"]]
    mans = list(result["by_maneuver"])
    fig = Figure(figsize=(max(6.0, 1.6 * len(names) + 2.0) + 3.0, 5.2), layout="constrained")
    ax = fig.add_subplot()
    width = 0.8 / max(len(mans), 1)
    colors = rcParamsDefault["axes.prop_cycle"].by_key()["color"]
    for i, m in enumerate(mans):
        xs, sd, cov = [], [], []
        for k, e in enumerate(names):
            cell = result["by_maneuver"][m].get(e, {})
            if cell.get("sd") is None:
                continue
            a = result["effects"][e]["magnitude"]
            xs.append(k + (i - (len(mans) - 1) / 2) * width)
            sd.append(cell["sd"] / a)
            cov.append(cell["sd_cov"] / a)
        col = colors[i % len(colors)]
        ax.bar(xs, sd, width=width, color=col, alpha=0.7, label=f"{m} (Monte Carlo)")
        ax.plot(xs, cov, "o", color=col, mec="k", ms=4, label=f"{m} (covariance)")
    ax.axhline(1.0 / result["min_t"], color="r", ls="--", lw=1,
               label=f"named from one recording (sd = magnitude / {result['min_t']:g})")
    ax.set_xticks(range(len(names)))
    ax.set_xticklabels([f"{e}\n{result['effects'][e]['nominal']:.3g} {result['effects'][e]['unit']}"
                        for e in names], fontsize=8)
    ax.set(yscale="log", ylabel="sd of the estimate / effect magnitude (one recording)",
           xlabel="effect (its magnitude in the study)")
    fig.suptitle((f"How precisely each maneuver measures each effect\n({result['rides']} rides of "
                  f"{result['duration']:g} s, sensor noise {result['noise_scale']:g}x paper, "
                  f"torques {'recorded' if result['with_torques'] else 'not recorded'})"),
                 fontsize=9)
    plain_log_ticks(ax.yaxis)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    hidden = [f"{e}: {v['reason']}" for e, v in result["effects"].items() if not v["visible"]]
    if hidden:
        fig.supxlabel("Not visible: " + "; ".join(hidden), fontsize=6, wrap=True)
    return fig
