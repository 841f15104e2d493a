"""Blind study of ``euc-sim diagnose``: recordings with a concealed effect, diagnosed blind.

For every effect of CONTRACT's catalog, recordings are simulated with that effect
injected at a magnitude drawn at random in its plausible range, on several
maneuvers (acceleration, deceleration, stop-and-go, with random speeds), with the
paper's measurement noise (0.2 mm, 0.5°) and a swaying rider (motor noise
3 N·m).  The truth goes to ``NAME.truth.json`` only; the diagnosis reads the CSV
and its ``NAME.json`` sidecar (parameters and the planned maneuver), never the
truth.  Also: null recordings (no effect), constant-speed recordings (which cannot
decide: h and a constant force alias), and an out-of-catalog disturbance (a
periodic horizontal push on the rider's centre of gravity).

Torques: the kinematic-visible effects are concealed in recordings without
torques (the paper's situation); ``wheel_bearing_friction`` and ``rider_mass`` are
internal / near the noise floor without torques, so they are concealed in
recordings *with* M_d (and, as a check of honesty, also without it, where the
right answer is "cannot be revealed").

Prints a confusion table (truth × first effect named), the estimate errors, the
held-out RMSE reductions and whether each target is met; writes
``OUT/summary.json``.

Usage::

    python scripts/tables/blind_study.py --out blind/ --per-effect 10 --nulls 6 --seed 0
    python scripts/tables/blind_study.py --calibrate      # null recordings only, other seeds
    python scripts/tables/blind_study.py --out pairs/ --per-effect 0 --nulls 0 --pushes 0 --constant 0 --pairs 36

``--laws N`` adds N concealed firmware laws, written as EUC World and WheelLog logs and
identified blind (``blind_laws.py`` here).

``--pairs N`` adds N recordings holding two effects of different families, each
member's size with the other known measured on its twin (the member alone, same seed),
scored by ``score_pairs`` of ``blind_scoring.py`` here.

Every random draw is seeded from ``--seed``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from blind_laws import plan_laws, print_laws, run_laws, score_laws
from blind_scoring import print_pairs, print_report, score, score_pairs
from euc_sim.identification.processing import DEFAULT_SMOOTHING
from euc_sim.io import to_jsonable

MANEUVERS = ("acceleration", "deceleration", "stop_and_go")
#: Effects concealed in recordings without torques / with M_d recorded.
KINEMATIC = ("rolling_resistance", "aerodynamic_drag", "road_slope", "sensor_time_offset",
             "cog_height_drift", "lateral_dynamics")
WITH_TORQUE = ("wheel_bearing_friction", "rider_mass")
#: Rider motor noise of the study's recordings, N·m (dataset.DEFAULT_RIDER_NOISE).
RIDER_NOISE = 3.0
#: The diagnosis's term filter, s: the library's default, at which the thresholds were set.
TERM_SIGMA = DEFAULT_SMOOTHING.term_sigma


def maneuver_options(name: str, rng: np.random.Generator) -> dict:
    """Random but plausible options of a built-in maneuver (m/s, s)."""
    if name == "acceleration":
        return {"v0": float(rng.uniform(0.5, 1.5)), "v1": float(rng.uniform(3.0, 4.5)),
                "start": float(rng.uniform(2.0, 4.0)), "ramp": float(rng.uniform(3.0, 5.0))}
    if name == "deceleration":
        return {"v0": float(rng.uniform(3.0, 4.5)), "v1": float(rng.uniform(0.3, 1.0)),
                "start": float(rng.uniform(2.0, 4.0)), "ramp": float(rng.uniform(3.0, 5.0))}
    if name == "stop_and_go":
        return {"v": float(rng.uniform(2.0, 3.0))}
    if name == "constant_speed":
        return {"v": float(rng.uniform(2.0, 4.0))}
    raise ValueError(f"maneuver: expected one of {', '.join(MANEUVERS)} or constant_speed, got {name!r}")


def draw_magnitude(name: str, rng: np.random.Generator, nominal_mass: float = 65.0) -> float:
    """A magnitude in the catalog's plausible range, in CONTRACT's unit."""
    from euc_sim.simulation import effects
    lo, hi = effects.get(name).plausible
    if name == "road_slope":
        return float(rng.choice([-1.0, 1.0]) * rng.uniform(0.01, max(abs(lo), abs(hi))))
    if name == "rider_mass":      # a mass that is not the nominal one: |Δm| ≥ 10 kg
        while True:
            m = float(rng.uniform(lo, hi))
            if abs(m - nominal_mass) >= 10.0:
                return m
    return float(rng.uniform(lo, hi))


#: Shapes of the drawn h drifts (simulation.drift), in turn.
DRIFT_KINDS = ("ramp", "dip", "wander", "sine")


def draw_drift_shape(j: int, duration: float, rng: np.random.Generator) -> dict:
    """The j-th drift's shape: a ramp or a dip of 2-6 s starting anywhere with 2 s to
    spare at each end, a slow wander, or the catalog's 12 s sine; crouching or
    standing up at random (as the keyword arguments of ``simulation.drift.DriftShape``)."""
    kind = DRIFT_KINDS[j % len(DRIFT_KINDS)]
    sign = float(rng.choice([-1.0, 1.0]))
    if kind in ("ramp", "dip"):
        length = float(rng.uniform(2.0, 6.0))
        start = float(rng.uniform(2.0, duration - length - 2.0))
        return {"kind": kind, "start": start, "length": length, "sign": sign}
    if kind == "wander":
        return {"kind": kind, "sign": sign, "seed": int(rng.integers(0, 2**31 - 1))}
    return {"kind": "sine"}


def plan(seed: int, per_effect: int, nulls: int, pushes: int, constant: int, duration: float,
         with_torque_checks: bool = True) -> list[dict]:
    """The study's cases, each a dict of everything needed to make one recording."""
    rng = np.random.default_rng(seed)
    cases = []

    def add(kind, effect, value, maneuver, hide, push=None, drift=None):
        i = len(cases)
        opts = maneuver_options(maneuver, rng)
        cases.append({"name": f"case{i:03d}", "kind": kind, "effect": effect, "value": value,
                      "maneuver": maneuver, "options": opts, "hide_torques": hide, "push": push,
                      "seed": int(rng.integers(1, 2**31 - 1)), "duration": duration, "drift_shape": drift})

    for name in KINEMATIC:
        for j in range(per_effect):
            shape = draw_drift_shape(j, duration, rng) if name == "cog_height_drift" else None
            add("effect", name, draw_magnitude(name, rng), MANEUVERS[j % len(MANEUVERS)], True, drift=shape)
    for name in WITH_TORQUE:
        for j in range(per_effect):
            add("effect", name, draw_magnitude(name, rng), MANEUVERS[j % len(MANEUVERS)], False)
        if with_torque_checks:   # the same effect without torques: must not be named
            add("invisible", name, draw_magnitude(name, rng), MANEUVERS[0], True)
    for j in range(nulls):
        add("null", None, 0.0, MANEUVERS[j % len(MANEUVERS)], j % 3 != 2)
    for j in range(pushes):
        push = {"amplitude": float(rng.uniform(15.0, 30.0)), "frequency": float(rng.uniform(0.3, 0.8))}
        add("push", None, 0.0, MANEUVERS[j % len(MANEUVERS)], True, push)
    for j in range(constant):
        name = KINEMATIC[j % 3]
        add("constant", name, draw_magnitude(name, rng), "constant_speed", True)
    return cases


#: Every catalog effect a pair may hold; a pair holding one of WITH_TORQUE records M_d.
PAIR_EFFECTS = KINEMATIC + WITH_TORQUE
#: The out-of-catalog push, as a pair's second member.
PUSH = "push"


def pair_families() -> list[tuple[str, str]]:
    """Every pair of different catalog effects, and every effect with the push."""
    fam = [(a, b) for i, a in enumerate(PAIR_EFFECTS) for b in PAIR_EFFECTS[i + 1:]]
    return fam + [(a, PUSH) for a in PAIR_EFFECTS]


def draw_push(rng: np.random.Generator) -> dict:
    """An out-of-catalog periodic push at G: amplitude N, frequency Hz."""
    return {"amplitude": float(rng.uniform(15.0, 30.0)), "frequency": float(rng.uniform(0.3, 0.8))}


def plan_pairs(seed: int, n: int, duration: float) -> list[dict]:
    """n recordings holding two effects of different families (``--pairs N``).

    The families (:func:`pair_families`) are dealt in a shuffled order, the
    magnitudes drawn as for single effects (:func:`draw_magnitude`, an h drift's
    shape by :func:`draw_drift_shape`), the maneuvers in turn; M_d is recorded when
    either member is internal or near the floor without it (``WITH_TORQUE``).  A
    stream of its own (``[seed, 24]``), so that adding pairs leaves the single cases
    unchanged.
    """
    rng = np.random.default_rng([seed, 24])
    fams = pair_families()
    order = [fams[i] for i in rng.permutation(len(fams))]
    cases = []
    for j in range(n):
        a, b = order[j % len(order)]
        maneuver = MANEUVERS[j % len(MANEUVERS)]
        eff = {e: draw_magnitude(e, rng) for e in (a, b) if e != PUSH}
        shape = draw_drift_shape(int(rng.integers(0, 4)), duration, rng) if "cog_height_drift" in eff else None
        cases.append({"name": f"pair{j:03d}", "kind": "pair", "effect": None, "value": 0.0, "effects": eff,
                      "family": f"{a}+{b}", "maneuver": maneuver, "options": maneuver_options(maneuver, rng),
                      "hide_torques": not any(e in WITH_TORQUE for e in (a, b)),
                      "push": draw_push(rng) if b == PUSH else None, "seed": int(rng.integers(1, 2**31 - 1)),
                      "duration": duration, "drift_shape": shape})
    return cases


def twins(case: dict) -> list[dict]:
    """A pair's members alone, on the same maneuver, seed and noise: each twin's nominal
    RMSE over its noise floor is that effect's size with the other known (the push too)."""
    members = list(case["effects"]) + ([PUSH] if case.get("push") else [])
    out = []
    for e in members:
        alone = {k: v for k, v in case["effects"].items() if k == e}
        out.append({**case, "name": f"{case['name']}_{e}", "kind": "twin", "effects": alone, "member": e,
                    "push": case["push"] if e == PUSH else None,
                    "drift_shape": case["drift_shape"] if e == "cog_height_drift" else None})
    return out


def floor_ratio(path: Path) -> dict:
    """The nominal model's held-out RMSE over the noise floor of a recording (as
    :func:`euc_sim.diagnosis.pipeline.diagnose` computes both, without the selection)."""
    from euc_sim.diagnosis.common import H_BOUNDS
    from euc_sim.diagnosis.prepare import prepare
    from euc_sim.diagnosis.residual import noise_floor, residual_model
    from euc_sim.identification import regression as reg
    prep = prepare(path, None, None)
    model = residual_model(prep)
    t = prep.kin.t[prep.keep]
    time_ = np.concatenate([t, t]) if model.W is not None else t
    problem = reg.Problem(model, {}, time_, H_BOUNDS)
    h0 = reg.fit_set(problem, ()).h
    floor = noise_floor(prep, h0, 0)["rms_stacked"]
    nominal = reg.heldout_rmse(problem, ())
    return {"nominal_rmse": nominal, "noise_floor": floor, "ratio": nominal / floor}


def plan_spatial(seed: int, n: int, duration: float) -> list[dict]:
    """n 3-D cases (``--spatial N``): a path of the spatial model with its speed and radius drawn
    (:func:`euc_sim.simulation.spatial.draw_spatial_ride`), scored as
    ``lateral_dynamics`` cases; the true value, the simulated peak tilt over the couplings'
    bandwidth (:func:`euc_sim.simulation.effects.band_peak_tilt` of the true 1 kHz tilt,
    CONTRACT's peak tilt), is filled in from the recording's truth file."""
    from euc_sim.simulation.spatial import draw_spatial_ride
    rng = np.random.default_rng([seed, 14])
    cases = []
    for j in range(n):
        ride = draw_spatial_ride(j, rng)
        cases.append({"name": f"spatial{j:03d}", "kind": "effect", "model": "3d", "effect": "lateral_dynamics",
                      "value": None, "maneuver": ride["path"],
                      "options": {"speed": ride["speed"], "radius": ride["radius"]}, "hide_torques": False,
                      "push": None, "seed": int(rng.integers(1, 2**31 - 1)), "duration": duration,
                      "drift_shape": None})
    return cases


def make_recording(case: dict, out: Path) -> Path:
    """Simulate one case and write NAME.csv, NAME.json (no truth in it), NAME.truth.json."""
    if case.get("model") == "3d":
        from euc_sim.simulation.spatial import write_spatial
        return write_spatial(**spatial_request(case, out))
    from euc_sim.simulation import dataset
    return _write_case(case, out, *dataset.simulated_recording(case_spec(case)))


def spatial_request(case: dict, out: Path) -> dict:
    """The keyword arguments of :func:`euc_sim.simulation.spatial.write_spatial` for a 3-D case."""
    return {"out": out / f"{case['name']}.csv", "path": case["maneuver"], "duration": case["duration"],
            "seed": case["seed"], "rider_noise": case.get("rider_noise", RIDER_NOISE),
            "speed": case["options"]["speed"],
            "radius": case["options"]["radius"], "hide_torques": case["hide_torques"],
            "noise": case.get("noise", "paper")}


def case_spec(case: dict):
    """The :class:`euc_sim.simulation.dataset.RecordingSpec` of a planar case."""
    from euc_sim.simulation import dataset
    from euc_sim.model.parameters import TABLE3
    from euc_sim.simulation.effects import PeriodicPush
    from euc_sim.simulation.engine import default_rider, true_params
    from euc_sim.simulation.drift import DriftShape
    from euc_sim.simulation.maneuvers import make_maneuver

    man = make_maneuver(case["maneuver"], **case["options"])
    eff = dict(case["effects"]) if case.get("effects") else ({case["effect"]: case["value"]} if case["effect"] else {})
    # the rider's own balance law is designed for the rider's true body (a heavier
    # rider knows his weight); the analysis still assumes Table 3
    rider = default_rider(true_params(TABLE3, eff), noise_std=RIDER_NOISE)
    shape = case.get("drift_shape")
    return dataset.RecordingSpec(case["name"], man, case["duration"], case["seed"],
                                 effects=tuple(eff.items()), hide_torques=case["hide_torques"],
                                 rider=rider,
                                 external_force=PeriodicPush(**case["push"]) if case["push"] else None,
                                 drift_shape=DriftShape(**shape) if shape else None)


def _write_case(case: dict, out: Path, rec, meta: dict, truth: dict) -> Path:
    """Write a case's recording with its options in the sidecar and the case in the truth file."""
    from euc_sim import io
    meta = {**meta, "maneuver_options": case["options"]}
    truth = {**truth, "case": case}
    path = out / f"{case['name']}.csv"
    io.write_recording(rec, path, meta, truth)
    return path


def _make_batch(args) -> int:
    """Worker: the planar cases' recordings as one MuJoCo batch (``simulated_recordings``);
    a case whose rider falls is left unwritten (its ``_work`` then says so). Returns how many fell."""
    cases, out = args
    from euc_sim.simulation import dataset
    made = dataset.simulated_recordings([case_spec(c) for c in cases])
    for case, res in zip(cases, made):
        if not isinstance(res, Exception):
            _write_case(case, out, *res)
    return sum(isinstance(res, Exception) for res in made)


def _make_spatial(args) -> int:
    """Worker: 3-D cases' recordings on ``nthread`` threads (``spatial_threads.ride_3d_many``);
    a case whose rider falls is left unwritten (its ``_work`` then says so). Returns how many fell."""
    cases, out, nthread = args
    from euc_sim.simulation.spatial import write_spatial
    from spatial_threads import ride_3d_many
    made = ride_3d_many([spatial_request(c, out) for c in cases], nthread=nthread, ride=write_spatial)
    return sum(isinstance(res, Exception) for res in made)


def make_recordings(cases: list[dict], out: Path, workers: int = 2, scheduler: str | None = None,
                    batch: int = 32) -> None:
    """The cases' missing recordings as tasks of :func:`euc_sim.simulation.runner.run_tasks`: the
    planar ones ``batch`` to a MuJoCo batch, the 3-D ones in groups of at most ``batch`` (as many
    groups as ``workers`` at least), each group on the cores a worker has to itself
    (``spatial_threads.ride_3d_many``; one thread under Dask). Same files as :func:`make_recording`."""
    from euc_sim.simulation.runner import run_tasks

    todo = [c for c in cases if not (out / f"{c['name']}.csv").exists()]
    flat = [c for c in todo if c.get("model") != "3d"]
    tasks = [(f"batch{i // batch:04d}", _make_batch, (flat[i:i + batch], out)) for i in range(0, len(flat), batch)]
    spatial = [c for c in todo if c.get("model") == "3d"]
    if spatial:
        w = max(1, workers or os.cpu_count() or 1)
        nthread = 1 if scheduler else max(1, (os.cpu_count() or 1) // w)
        size = min(batch, -(-len(spatial) // w))
        tasks += [(f"spatial{i // size:04d}", _make_spatial, (spatial[i:i + size], out, nthread))
                  for i in range(0, len(spatial), size)]
    if tasks:
        run_tasks(_make_task, [(name, (fn, arg)) for name, fn, arg in tasks],
                  scheduler=scheduler, workers=workers, desc="blind study rides")


def _make_task(args) -> int:
    """Worker: one task of :func:`make_recordings` (a planar MuJoCo batch or a 3-D group)."""
    fn, arg = args
    return fn(arg)


def _work(args):
    case, out, resimulate, term_sigma = args
    from euc_sim.diagnosis import pipeline as diagnosis
    warnings.simplefilter("ignore")
    path = out / f"{case['name']}.csv"
    t0 = time.perf_counter()
    try:
        if not path.exists():
            make_recording(case, out)
    except ValueError as exc:          # a fall: the case is dropped, and said so
        return {"case": case, "error": f"simulation: {str(exc).splitlines()[0]}"}
    if case.get("model") == "3d":      # the truth of a 3-D ride: its simulated peak tilt (band_peak_tilt)
        truth = json.loads((out / f"{case['name']}.truth.json").read_text())
        case = {**case, "value": truth["peak_tilt_rad"]}
    t1 = time.perf_counter()
    res = diagnosis.diagnose(path, resimulate=resimulate,       # the CSV and its sidecar only
                             smoothing=replace(DEFAULT_SMOOTHING, term_sigma=term_sigma))
    t2 = time.perf_counter()
    view = diagnosis.json_view(res)
    (out / f"{case['name']}.diagnosis.json").write_text(json.dumps(to_jsonable(view), indent=1))
    if case["kind"] == "pair":       # each member's size with the other known: its twin alone
        case = {**case, "twin_ratio": _twin_ratios(case, out)}
    kept = {k: view[k] for k in ("effects", "unexplained", "nominal_rmse", "augmented_rmse", "verdict", "decidable",
                                 "noise_floor", "generic", "h_nominal", "h_augmented", "limits", "history",
                                 "windows", "tentative", "cannot_see")}
    kept["lateral_calibration"] = view.get("lateral_calibration")     # a 3-D ride's twin (coverage_3d)
    return {"case": case, "result": kept, "t_sim": t1 - t0, "t_diag": t2 - t1}


def _twin_ratios(case: dict, out: Path) -> dict:
    """{member: nominal RMSE / noise floor of the member alone} (None where its twin fell)."""
    ratios = {}
    for tw in twins(case):
        path = out / f"{tw['name']}.csv"
        try:
            if not path.exists():
                make_recording(tw, out)
            ratios[tw["member"]] = floor_ratio(path)["ratio"]
        except ValueError:
            ratios[tw["member"]] = None
    return ratios


def run(cases: list[dict], out: Path, workers: int = 2, resimulate: bool = False,
        progress=print, term_sigma: float = TERM_SIGMA, scheduler: str | None = None) -> list[dict]:
    """Make and diagnose every case (term filter ``term_sigma`` s) with
    :func:`euc_sim.simulation.runner.run_tasks`: ``workers`` processes, or Dask with
    ``scheduler`` ("local" or an address; a remote cluster's workers must see ``out``)."""
    from euc_sim.simulation.runner import run_tasks

    out.mkdir(parents=True, exist_ok=True)
    make_recordings(cases, out, workers, scheduler)
    rep = run_tasks(_work, [(c["name"], (c, out, resimulate, term_sigma)) for c in cases],
                    scheduler=scheduler, workers=workers, desc="blind study")
    progress(rep.table())
    return [rep.results[c["name"]] if c["name"] in rep.results else {"case": c, "error": rep.failed[c["name"]]}
            for c in cases]


def first_step_best(history: list[dict]) -> dict:
    """The strongest candidate of a diagnosis's first selection step.

    Parameters
    ----------
    history : list of dict
        The diagnosis JSON's ``history``.

    Returns
    -------
    dict
        ``bic_drop`` (largest BIC drop below the nominal model), ``t`` (largest
        |θ|/se judged) and ``cv_gain`` (largest held-out gain judged); 0 when no
        candidate was tried.  On null recordings these are what acceptance must
        stay above.
    """
    base = history[0]["trials"][0]["bic"]
    trials = history[1]["trials"] if len(history) > 1 else []
    return {"bic_drop": max((base - d["bic"] for d in trials), default=0.0),
            "t": max((d.get("t", 0.0) for d in trials), default=0.0),
            "cv_gain": max((d.get("cv_gain", 0.0) for d in trials), default=0.0)}


def calibrate(out: Path, seed: int, n: int, workers: int, duration: float,
              term_sigma: float = TERM_SIGMA) -> dict:
    """Null recordings only (other seeds than the study): the distribution of the
    statistics that decide 'unexplained' and acceptance, for choosing thresholds."""
    rng = np.random.default_rng(seed)
    cases = []
    for j in range(n):
        m = MANEUVERS[j % len(MANEUVERS)]
        cases.append({"name": f"null{j:03d}", "kind": "null", "effect": None, "value": 0.0, "maneuver": m,
                      "options": maneuver_options(m, rng), "hide_torques": True, "push": None,
                      "seed": int(rng.integers(1, 2**31 - 1)), "duration": duration})
    results = run(cases, out, workers, term_sigma=term_sigma)
    gains = [r["result"]["generic"]["gain"] for r in results if "result" in r]
    ratios = [r["result"]["generic"]["floor_ratio"] for r in results if "result" in r]
    named = [r["result"]["effects"][0]["name"] for r in results if "result" in r and r["result"]["effects"]]
    best = [first_step_best(r["result"]["history"]) for r in results if "result" in r]
    bic_drop, t_best, cv_best = ([b[k] for b in best] for k in ("bic_drop", "t", "cv_gain"))
    return {"n": len(results), "generic_gain_max": max(gains), "generic_gain_p90": float(np.percentile(gains, 90)),
            "floor_ratio_max": max(ratios), "floor_ratio_p90": float(np.percentile(ratios, 90)),
            "effects_named": named, "bic_drop_max": max(bic_drop), "bic_drop_p90": float(np.percentile(bic_drop, 90)),
            "t_max": max(t_best), "cv_gain_max": max(cv_best)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="blind-study", help="folder for the recordings and results")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--per-effect", type=int, default=6, help="recordings per catalog effect")
    ap.add_argument("--nulls", type=int, default=6)
    ap.add_argument("--pushes", type=int, default=3)
    ap.add_argument("--constant", type=int, default=3, help="constant-speed recordings")
    ap.add_argument("--duration", type=float, default=20.0, help="s")
    ap.add_argument("--workers", type=int, default=2,
                    help="processes on this machine (1: in this process), or the workers of --scheduler local")
    ap.add_argument("--scheduler", default=None, metavar="local|ADDRESS",
                    help="run on Dask: 'local' starts a local cluster, tcp://HOST:PORT uses a running one")
    ap.add_argument("--resimulate", action="store_true", help="also re-simulate each maneuver (slower)")
    ap.add_argument("--spatial", type=int, default=0, metavar="N",
                    help="also N rides of the 3-D model (circle, slalom, figure-eight, U-turn)")
    ap.add_argument("--pairs", type=int, default=0, metavar="N",
                    help="also N recordings holding two effects of different families")
    ap.add_argument("--laws", type=int, default=0, metavar="N",
                    help="also N concealed firmware laws in EUC World / WheelLog logs")
    ap.add_argument("--law-duration", type=float, default=300.0, help="s, of each concealed-law ride")
    ap.add_argument("--law-boot", type=int, default=20, help="bootstrap replicates of each law's intervals")
    ap.add_argument("--calibrate", action="store_true", help="null recordings only (seed + 1000)")
    ap.add_argument("--term-sigma", type=float, default=TERM_SIGMA, metavar="S",
                    help=f"the diagnosis's term filter, s (default {TERM_SIGMA:g}; the thresholds "
                         "were set at the default: other values are for the filter study)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    t0 = time.perf_counter()
    if args.calibrate:
        cal = calibrate(out / "calibration", args.seed + 1000, max(args.nulls, 12), args.workers, args.duration,
                        args.term_sigma)
        print(json.dumps(cal, indent=1))
        return 0
    cases = plan(args.seed, args.per_effect, args.nulls, args.pushes, args.constant, args.duration,
                 with_torque_checks=args.per_effect > 0)
    cases += plan_spatial(args.seed, args.spatial, max(args.duration, 20.0))
    cases += plan_pairs(args.seed, args.pairs, args.duration)
    laws = plan_laws(args.seed, args.laws, args.law_duration)
    print(f"blind study: {len(cases) + len(laws)} recordings in {out}/ (seed {args.seed})")
    results = run(cases, out, args.workers, args.resimulate, term_sigma=args.term_sigma,
                  scheduler=args.scheduler) if cases else []
    singles = [r for r in results if r["case"]["kind"] != "pair"]
    summary = score(singles) if singles else {}
    summary["pairs"] = score_pairs(results)
    law_results = run_laws(laws, out, args.workers, args.law_boot, args.scheduler) if laws else []
    summary["laws"] = score_laws(law_results)
    summary["law_cases"] = law_results
    summary["seconds"] = time.perf_counter() - t0
    summary["command"] = " ".join(sys.argv)
    if singles:
        print_report(summary)
    print_pairs(summary["pairs"])
    print_laws(summary["laws"])
    print(f"\n{summary['seconds']:.0f} s")
    from euc_sim.io import write_json
    write_json(out / "summary.json", summary)
    return 0


if __name__ == "__main__":
    sys.exit(main())
