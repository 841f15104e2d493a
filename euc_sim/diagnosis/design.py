"""Experiment design for the catalog effects: how precisely each maneuver measures each one.

:mod:`euc_sim.identification.design` answers the question for h; this module answers
it for CONTRACT's effects, with the diagnosis's own regression, so the figures are
those a diagnosis of such recordings would report.

For each maneuver and each effect:

* Monte Carlo: R recordings simulated with the effect present at a nominal
  magnitude (:func:`nominal_magnitude`, the geometric middle of the catalog's
  plausible range) and the paper's sensor noise (times a scale), each diagnosed as
  :func:`euc_sim.diagnosis.pipeline.diagnose` would fit that effect: the recording
  prepared (:func:`euc_sim.diagnosis.prepare.prepare`), the candidate library built
  (:func:`euc_sim.diagnosis.candidates.build_problem`) and the nominal model plus
  that effect's term fitted jointly with h (:func:`euc_sim.identification.regression.fit_set`).
  ``sd`` is the spread of the R estimates (one recording each), ``bias`` their mean
  minus the truth.
* Covariance prediction: the same fit's cluster-robust covariance
  (:func:`euc_sim.identification.regression.covariance`, the diagnosis's standard
  errors), mapped to the effect's unit (:func:`euc_sim.diagnosis.estimates.estimate_of`);
  ``sd_cov`` is the root mean of the R predicted variances.  It is the analogue of
  the Fisher prediction of h's design for a residual that is not white.

Recordings needed: independent recordings pool to sd/√n, so n = ⌈(sd / (f·|a|))²⌉
for a target sd of a fraction f of the effect's magnitude a (``recordings_for``), and
n = ⌈(min_t·sd / |a|)²⌉ for the effect to stand ``min_t`` standard errors from zero,
the diagnosis's threshold for naming it (``recordings_to_detect``).

Effects a recording cannot reveal (a column missing: the torque M_d for the rider
mass and the bearing friction when torques are not recorded) are listed with the
diagnosis's reason and no figures.

Seeds: run seed S gives the (maneuver i, effect j) task the child
``SeedSequence(S, spawn_key=(1, i, j))``, each ride one grandchild, so a task's
figures do not depend on which other maneuvers and effects are studied.
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
from euc_sim.identification.design import DESIGN_MANEUVERS
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
#: Cluster length of the diagnosis's covariance, s (as its detection limits).
CLUSTER = 2.0
#: Columns of a recording with (without) the torques, for the visibility rules.
_COLUMNS = ("t", "x", "gamma", "phi")
#: The design's maneuvers are planar: the lateral effect's tilt and yaw come from its
#: own slalom (:func:`euc_sim.simulation.maneuvers.lateral_profile`) and are recorded.
_LATERAL_COLUMNS = ("psi", "theta")


def nominal_magnitude(name: str, params: Params = TABLE3) -> float:
    """The effect's value in the Monte Carlo, in its CONTRACT unit.

    The geometric middle of the catalog's plausible range (the diagnosis's range for
    detection limits, :func:`euc_sim.diagnosis.common.plausible_range`); for
    ``rider_mass`` the nominal mass plus that middle deviation, kg.
    """
    lo, hi = plausible_range(name)
    mid = math.sqrt(lo * hi)
    return fx.RECORDS.absent_value(name, params) + mid


def parse_effects(text: str) -> list[str]:
    """``"all"`` or comma-separated CONTRACT effect names → the list, checked.

    Raises
    ------
    ValueError
        naming ``--effect`` and the unknown or repeated names.
    """
    names = list(fx.CATALOG) if text.strip() == "all" else [e.strip() for e in text.split(",") if e.strip()]
    bad = [e for e in names if e not in fx.CATALOG]
    if not names or bad:
        raise InputError(f"--effect: unknown {', '.join(bad) or '(none given)'}; "
                         f"valid: all, {', '.join(fx.CATALOG)}")
    if len(set(names)) != len(names):
        raise InputError(f"--effect: an effect is listed twice in {text}")
    return names


def _magnitude(name: str, value: float, params: Params) -> float:
    """|value − no effect|: the size the precision is relative to."""
    return abs(value - fx.RECORDS.absent_value(name, params))


def effect_estimate(recording, meta: dict, name: str, params: Params, h0: float) -> tuple[float, float]:
    """The diagnosis's estimate of one effect on one recording, and its standard error.

    Parameters
    ----------
    recording : pandas.DataFrame
        A CONTRACT recording.
    meta : dict
        Its sidecar.
    name : str
        The effect (a candidate of :func:`euc_sim.diagnosis.candidates.build_problem`).
    params : Params
        Nominal parameters.
    h0 : float
        h at which the candidate columns are built, m.

    Returns
    -------
    (estimate, se) : (float, float)
        In the effect's unit.

    Raises
    ------
    ValueError
        when the recording cannot reveal the effect.
    """
    prep = prepare(recording, params=params, meta=meta)
    problem, info = build_problem(prep, h0)
    if name not in problem.candidates:
        raise InputError(f"effect {name!r}: not a candidate of this recording "
                         f"(candidates: {', '.join(problem.candidates)})")
    fit = reg.fit_set(problem, (name,))
    cov, dof = reg.covariance(problem, fit, cluster=CLUSTER)
    est, _, se = estimate_of(info[name], fit.theta[name], sub_cov(problem, (name,), cov, name), dof)
    return float(est), float(se)


def effect_study(args) -> dict:
    """One (maneuver, effect): R recordings with the effect present, each diagnosed.

    Parameters
    ----------
    args : tuple
        ``(maneuver, effect, value, rides, duration, noise_scale, (seed, i, j), params,
        rider_noise, with_torques)`` (one tuple: a task of
        :func:`euc_sim.simulation.runner.run_tasks`).

    Returns
    -------
    dict
        ``estimates`` and ``se`` (one per ride that did not fall), ``fell``.
    """
    name, effect, value, rides, duration, scale, (seed, i, j), p, rider_noise, with_torques = args
    seeds = [int(c.generate_state(1)[0])
             for c in np.random.SeedSequence(seed, spawn_key=(1, i, j)).spawn(rides)]
    rider = default_rider(true_params(p, {effect: value}), noise_std=rider_noise)   # he knows his weight
    sig_pos, sig_ang = NOISE_LEVELS["paper"]
    specs = [RecordingSpec(f"{name}-{effect}-{s}", make_maneuver(name), duration, s, params=p,
                           effects=((effect, value),), noise=(scale * sig_pos, scale * sig_ang),
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


def _recordings(sd: float, magnitude: float, fraction: float) -> int:
    return max(1, int(math.ceil((sd / (fraction * magnitude)) ** 2)))


def effects_design(maneuvers: Sequence[str], effect_names: Sequence[str], *, rides: int = 10,
                   duration: float = 15.0, noise_scale: float = 1.0, seed: int = 0,
                   params: Params = TABLE3, rider_noise: float = 3.0, with_torques: bool = False,
                   scheduler: str | None = None, workers: int | None = None,
                   progress: bool = True) -> dict:
    """How precisely each maneuver measures each catalog effect, by Monte Carlo and covariance.

    Parameters
    ----------
    maneuvers : sequence of str
        Names of :data:`euc_sim.identification.design.DESIGN_MANEUVERS`.
    effect_names : sequence of str
        CONTRACT effect names.
    rides : int
        Monte Carlo recordings per (maneuver, effect), at least 3.
    duration : float
        Length of each recording, s.
    noise_scale : float
        Sensor noise as a multiple of the paper's (0.2 mm, 0.5°).
    seed : int
    params : Params
        Nominal parameters (h: the truth).
    rider_noise : float
        Rider motor noise, N·m.
    with_torques : bool
        Record M_d and M_h (the wheel row of the diagnosis; the rider mass and the
        bearing friction become visible).
    scheduler, workers, progress
        See :func:`euc_sim.simulation.runner.run_tasks` (one task per maneuver and effect).

    Returns
    -------
    dict
        ``effects`` (per effect: ``nominal``, ``magnitude``, ``unit``, ``visible``,
        ``reason``), ``by_maneuver`` (maneuver → effect → ``sd``, ``sd_cov``,
        ``bias``, ``recordings_for`` (target fraction of the magnitude → n),
        ``recordings_to_detect``, ``rides``, ``fell``), ``best`` (effect → maneuver
        with the smallest sd) and the settings.

    Raises
    ------
    ValueError
        naming the argument, for unknown effects or maneuvers, or bad numbers.
    """
    _check(maneuvers, effect_names, rides, duration, noise_scale, DESIGN_MANEUVERS)
    cols = _COLUMNS + (("M_d", "M_h") if with_torques else ())
    table = {}
    for e in effect_names:
        vis = visibility(cols + (_LATERAL_COLUMNS if e == "lateral_dynamics" else ()))[e]
        value = nominal_magnitude(e, params)
        table[e] = {"nominal": value, "magnitude": _magnitude(e, value, params), "unit": fx.get(e).unit,
                    "visible": vis["visible"], "reason": vis["reason"]}
    tasks = [(f"{m}/{e}", (m, e, table[e]["nominal"], rides, float(duration), float(noise_scale),
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
            "duration": float(duration), "noise_scale": float(noise_scale), "with_torques": bool(with_torques),
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
                "recordings_for": {f"{f:g}": _recordings(sd, a, f) for f in RELATIVE_TARGETS},
                "recordings_to_detect": _recordings(sd, a, 1.0 / THRESHOLDS.min_t)})
    return out


def _check(maneuvers, effect_names, rides, duration, noise_scale, valid_maneuvers) -> None:
    bad = [m for m in maneuvers if m not in valid_maneuvers]
    if not maneuvers or bad:
        raise InputError(f"--maneuvers: unknown {', '.join(bad) or '(none given)'}; "
                         f"valid: {', '.join(valid_maneuvers)}")
    parse_effects(",".join(effect_names))
    if not (isinstance(rides, int) and rides >= 3):
        raise InputError(f"--effect-rides must be an integer of at least 3, got {rides!r}")
    if not (math.isfinite(duration) and duration >= 5.0):
        raise InputError(f"--duration must be at least 5 s (the fit's filters need it), got {duration!r}")
    if not (math.isfinite(noise_scale) and noise_scale > 0):
        raise InputError(f"noise_scale must be positive, got {noise_scale!r}")


def effects_design_figure(result: dict):
    """Each effect's sd from one recording relative to its magnitude, per maneuver:
    Monte Carlo (bars) and the covariance prediction (markers), with the diagnosis's
    detection line (1/min_t).

    Returns
    -------
    matplotlib.figure.Figure
    """
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
