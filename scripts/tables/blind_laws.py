"""Concealed-law cases of the blind study: a firmware law drawn at random,
ridden in closed loop, written as a real log, identified blind, scored on its gains and onset.

Each case draws a law (:func:`euc_sim.rides.synth.lawsynth.draw_law`: K_p 1,500-5,000 N·m/rad,
K_d 100-400, tilt-back 2° reached 10 km/h above an onset in 24-34 km/h, a torque limit of
45-70 N·m) and a log format in turn (EUC World: 5 Hz at irregular times, 0.1° pitch steps,
phase current; WheelLog: repeated stamps, 0.01° pitch, torque), rides it with the LQR rider
(0.2 s delay, 5 N·m motor noise) and writes NAME.csv, NAME.json (the wheel's torque constant,
N·m/A: what the drivetrain fit gives on a real ride) and NAME.truth.json.  The identification
(:func:`euc_sim.rides.law.controller_law.fit_law`) reads the CSV and the sidecar only.  A ride that
falls is ridden again on the next seed of its stream (at most :data:`TRIES` times; the falls
are counted).  Scored: K_p and K_d within ±15 %, the tilt-back onset within ±2 km/h (a law
without a kept tilt-back misses the onset), the sign convention.

    python scripts/tables/blind_study.py --out /tmp/laws --per-effect 0 --nulls 0 --pushes 0 --constant 0 --laws 12
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

#: Log formats, dealt in turn.
FORMATS = ("eucworld", "wheellog")
#: Rides tried per case before it is dropped as a fall.
TRIES = 3
#: Targets of the concealed-law cases: relative gain error, onset error (km/h).
GAIN_TOL, ONSET_TOL = 0.15, 2.0


def plan_laws(seed: int, n: int, duration: float) -> list[dict]:
    """n concealed-law cases (``--laws N``), from a stream of their own (``[seed, 21]``)."""
    from euc_sim.rides.synth.lawsynth import draw_law
    rng = np.random.default_rng([seed, 21])
    cases = []
    for j in range(n):
        law = draw_law(rng)
        cases.append({"name": f"law{j:03d}", "kind": "law", "format": FORMATS[j % len(FORMATS)],
                      "law": law, "sign": int(rng.choice([-1, 1])), "duration": duration,
                      "seed": int(rng.integers(1, 2**31 - 1))})
    return cases


def make_law_log(case: dict, out: Path) -> tuple[Path, dict]:
    """Ride the case's law and write NAME.csv, NAME.json (k_t), NAME.truth.json.

    Raises
    ------
    ValueError
        the rider fell on every one of :data:`TRIES` seeds.
    """
    from euc_sim.rides.synth.lawsynth import K_T, eucworld_log, law_ride, wheellog_log
    from euc_sim.simulation.errors import FallError
    falls = []
    for k in range(TRIES):
        seed = case["seed"] + 7919 * k
        try:
            ride = law_ride(seed=seed, duration=case["duration"], law=case["law"])
            break
        except FallError as exc:
            falls.append(str(exc).splitlines()[0])
    else:
        raise ValueError(f"{case['name']}: the rider fell on all {TRIES} seeds ({'; '.join(falls)})")
    path = out / f"{case['name']}.csv"
    write = eucworld_log if case["format"] == "eucworld" else wheellog_log
    write(ride, path, seed=seed, sign=case["sign"])
    (out / f"{case['name']}.json").write_text(json.dumps({"k_t": K_T}))
    truth = {"case": case, "ride_seed": seed, "falls": falls}
    (out / f"{case['name']}.truth.json").write_text(json.dumps(truth, indent=1))
    return path, truth


def law_work(args) -> dict:
    """Make one case and identify its law blind: the estimates, the kept terms, the falls."""
    import warnings

    from euc_sim.rides.grids.law_signals import LawUnavailable, law_rows
    from euc_sim.rides.law.controller_law import fit_law
    from euc_sim.rides.source.logs import read_log
    case, out, n_boot = args
    warnings.simplefilter("ignore")
    out.mkdir(parents=True, exist_ok=True)
    try:
        path, truth = make_law_log(case, out)
    except ValueError as exc:
        return {"case": case, "error": f"simulation: {exc}"}
    k_t = json.loads((out / f"{case['name']}.json").read_text())["k_t"]
    try:
        law = fit_law(law_rows(read_log(path, emit_warnings=False), k_t=k_t), n_boot=n_boot, seed=0)
    except LawUnavailable as exc:
        return {"case": case, "falls": len(truth["falls"]), "result": {"law": None, "why": str(exc)}}
    est = {k: v for k, (v, _, _) in law.terms.items()}
    return {"case": case, "falls": len(truth["falls"]),
            "result": {"law": law.names, "sign": law.sign, "K_p": est["K_p"], "K_d": est["K_d"],
                       "tiltback_speed": est.get("tiltback_speed"), "torque_limit": est.get("torque_limit"),
                       "heldout_r2": law.heldout_r2}}


def law_outcome(rec: dict) -> dict | None:
    """Errors of one identified case: relative K_p and K_d errors, onset error (km/h, None
    without a kept tilt-back), sign right; None when it fell or gave no law."""
    res = rec.get("result")
    if res is None or res["law"] is None:
        return None
    law = rec["case"]["law"]
    onset = res["tiltback_speed"]
    return {"format": rec["case"]["format"], "kp_err": res["K_p"] / law["Kp"] - 1.0,
            "kd_err": res["K_d"] / law["Kd"] - 1.0,
            "onset_err_kmh": None if onset is None else (onset - law["tiltback_speed"]) * 3.6,
            "sign_right": res["sign"] == rec["case"]["sign"]}


def score_laws(results: list[dict]) -> dict:
    """Per format: cases, dropped (fell on every seed), no law, and the shares within the
    targets (K_p, K_d ±15 %, onset ±2 km/h, all three, the sign), with the errors' medians
    and worst values."""
    out = {}
    for fmt in FORMATS:
        recs = [r for r in results if r["case"].get("kind") == "law" and r["case"]["format"] == fmt]
        if not recs:
            continue
        oc = [o for o in map(law_outcome, recs) if o is not None]
        ok_kp = [abs(o["kp_err"]) <= GAIN_TOL for o in oc]
        ok_kd = [abs(o["kd_err"]) <= GAIN_TOL for o in oc]
        ok_on = [o["onset_err_kmh"] is not None and abs(o["onset_err_kmh"]) <= ONSET_TOL for o in oc]
        share = (lambda xs: float(np.mean(xs)) if xs else math.nan)   # noqa: E731
        worst = (lambda xs: float(max(xs, key=abs)) if xs else math.nan)   # noqa: E731
        onsets = [o["onset_err_kmh"] for o in oc if o["onset_err_kmh"] is not None]
        out[fmt] = {"cases": len(recs), "dropped": sum("error" in r for r in recs),
                    "falls": sum(r.get("falls", 0) for r in recs),
                    "no_law": sum(1 for r in recs if r.get("result", {}).get("law", 0) is None),
                    "scored": len(oc), "kp_within": share(ok_kp), "kd_within": share(ok_kd),
                    "onset_within": share(ok_on),
                    "all_within": share([a and b and c for a, b, c in zip(ok_kp, ok_kd, ok_on)]),
                    "sign_right": share([o["sign_right"] for o in oc]),
                    "kp_err_median": float(np.median([o["kp_err"] for o in oc])) if oc else math.nan,
                    "kp_err_worst": worst([o["kp_err"] for o in oc]),
                    "kd_err_median": float(np.median([o["kd_err"] for o in oc])) if oc else math.nan,
                    "kd_err_worst": worst([o["kd_err"] for o in oc]),
                    "onset_err_worst_kmh": worst(onsets)}
    return out


def print_laws(summary: dict, out=print) -> None:
    """The concealed-law table, for people."""
    if not summary:
        return
    out("\nconcealed firmware laws (targets: K_p, K_d within ±15 %, onset within ±2 km/h):")
    out(f"{'format':<10}{'cases':>6}{'scored':>7}{'K_p ok':>8}{'K_d ok':>8}{'onset ok':>9}{'all':>6}"
        f"{'sign':>6}  K_p err med/worst   K_d err med/worst   onset worst  falls  no law")
    for fmt, s in summary.items():
        out(f"{fmt:<10}{s['cases']:>6}{s['scored']:>7}{s['kp_within']:>8.0%}{s['kd_within']:>8.0%}"
            f"{s['onset_within']:>9.0%}{s['all_within']:>6.0%}{s['sign_right']:>6.0%}  "
            f"{s['kp_err_median']:+6.1%} / {s['kp_err_worst']:+6.1%}    {s['kd_err_median']:+6.1%} / "
            f"{s['kd_err_worst']:+6.1%}    {s['onset_err_worst_kmh']:+5.1f} km/h  {s['falls']:>5}  {s['no_law']:>6}")


def run_laws(cases: list[dict], out: Path, workers: int = 2, n_boot: int = 20,
             scheduler: str | None = None, progress=print) -> list[dict]:
    """Make and identify every concealed-law case with
    :func:`euc_sim.simulation.runner.run_tasks`."""
    from euc_sim.simulation.runner import run_tasks
    out.mkdir(parents=True, exist_ok=True)
    rep = run_tasks(law_work, [(c["name"], (c, out, n_boot)) for c in cases], scheduler=scheduler,
                    workers=workers, desc="concealed laws")
    progress(rep.table())
    return [rep.results[c["name"]] if c["name"] in rep.results else {"case": c, "error": rep.failed[c["name"]]}
            for c in cases]
