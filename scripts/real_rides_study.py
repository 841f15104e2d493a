"""The blind total-mass estimate and the drivetrain on the 18 real rides of nine wheels.

Usage (from the repository root)::

    python scripts/real_rides_study.py [--n-boot 200] [--json OUT.json]

Reads ``../shared/data/euc_core/`` (rides, ``meta.csv`` and ``specs/``).  The tool
(:func:`euc_sim.rides.drivetrain_report.analyse`) sees only the log; the rider's
stated weight in ``meta.csv`` and the spec's net weight are used here, and only
here, to score it: truth = rider weight + wheel net weight.

Every ride's mass comes from that ride alone (no constant is learnt from other
rides, so nothing needs leaving out), from the energy balance over 2, 4 and 8 s
windows (the column "by window"; the estimate is their median, the interval
pools them).  Held-out errors: this ride's fit predicts
each other ride of the same wheel (battery power, W; PWM, percentage points), and
the column gives their mean.  Prints one markdown table and the summary lines.
"""

from __future__ import annotations

import argparse
import csv
import sys
import warnings
from pathlib import Path

import numpy as np

from euc_sim.io import write_json
from euc_sim.rides.drivetrain import predict_pwm
from euc_sim.rides.drivetrain_report import analyse, computed_pwm_note
from euc_sim.rides.mass import predict_power
from euc_sim.rides.power import MassSettings
from euc_sim.rides.spec import read_spec

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "euc_core"


def rides(root: Path = DATA) -> list[dict]:
    """Every ride with its meta row (for scoring only) and its spec file."""
    out = []
    for meta in sorted(root.glob("trips/*/*/*/meta.csv")):
        with open(meta, newline="") as fh:
            row = next(csv.DictReader(fh))
        folder = meta.parent
        out.append({"wheel": row["wheel"], "ride": folder.name, "app": row["app"],
                    "log": folder / f"{folder.name}.csv", "rider_weight": float(row["rider_weight"]),
                    "spec": root / "specs" / f"{row['wheel']}.csv"})
    return out


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def study(n_boot: int, seed: int, progress=print) -> list[dict]:
    """Fit every ride, score it, and predict the other rides of its wheel."""
    settings = MassSettings(n_boot=n_boot, seed=seed)
    items = rides()
    fits = {}
    for k, it in enumerate(items):
        progress(f"[{k + 1}/{len(items)}] {it['wheel']}/{it['ride']}", file=sys.stderr)
        spec = read_spec(it["spec"])
        fits[k] = analyse(it["log"], spec, settings)
        it["truth"] = it["rider_weight"] + spec.wheel_mass
    rows = []
    for k, it in enumerate(items):
        r = fits[k]
        m = r.mass
        others = [j for j, o in enumerate(items) if o["wheel"] == it["wheel"] and j != k]
        p_err, pwm_err = [], []
        for j in others:
            pred, obs = predict_power(fits[j].sig, m)
            p_err.append(_rms(pred - obs))
            if r.drivetrain.pwm_coef is not None and "pwm" in fits[j].sig.extra:
                pp, po = predict_pwm(fits[j].sig, r.drivetrain.pwm_coef)
                pwm_err.append(_rms(pp - po))
        est = m.estimate
        err = (est - it["truth"]) / it["truth"] if est is not None else float("nan")
        inside = bool(m.ci95 and m.ci95[0] <= it["truth"] <= m.ci95[1])
        rows.append({"wheel": it["wheel"], "ride": it["ride"], "app": it["app"],
                     "rider_weight": it["rider_weight"], "truth": it["truth"], "estimate": est,
                     "ci95": list(m.ci95) if m.ci95 else None, "error": err, "inside": inside,
                     "lag_s": m.lag, "speed_scale": m.scale.estimate,
                     "scale_source": m.scale.source, "signed": m.signed,
                     "power_heldout_W": float(np.mean(p_err)) if p_err else None,
                     "pwm_heldout_pp": float(np.mean(pwm_err)) if pwm_err else None,
                     "pwm_computed": computed_pwm_note(r) is not None,
                     "by_window": {f"{w:g}": x for w, x in m.by_window.items()},
                     "terms": m.terms, "unidentified": list(r.drivetrain.unidentified)})
    return rows


def table(rows: list[dict]) -> str:
    """The markdown table and the summary."""
    f = lambda x, fmt: "–" if x is None or x != x else format(x, fmt)   # noqa: E731
    lines = ["| wheel | ride | app | rider kg (logged) | truth kg | total mass found kg (95 %) "
             "| error | in CI | by window (2/4/8 s) kg | speed scale | held-out power W | held-out PWM pts "
             "| accepted terms |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        ci = f"[{r['ci95'][0]:.0f}, {r['ci95'][1]:.0f}]" if r["ci95"] else ""
        found = f"{r['estimate']:.0f} {ci}" if r["estimate"] is not None else "not identified"
        scale = f"{r['speed_scale']:.3f}" + ("" if r["scale_source"] == "gps" else " (assumed)")
        lines.append(
            f"| {r['wheel']} | {r['ride']} | {r['app']}{'' if r['signed'] else ' (unsigned I)'} "
            f"| {r['rider_weight']:g} | {r['truth']:.1f} | {found} "
            f"| {f(100 * r['error'], '+.0f')} % | {'yes' if r['inside'] else 'no'} "
            f"| {'/'.join(format(x, '.0f') for x in r['by_window'].values()) or '–'} | {scale} | {f(r['power_heldout_W'], '.0f')} "
            f"| {'(app-computed PWM)' if r['pwm_computed'] else f(r['pwm_heldout_pp'], '.1f')} "
            f"| {', '.join(r['terms']) or '–'} |")
    # a ride whose mass the tool cannot identify counts as a 100 % error
    err = np.array([abs(r["error"]) if r["error"] == r["error"] else 1.0 for r in rows])
    inside = sum(r["inside"] for r in rows)
    pwm = [r["pwm_heldout_pp"] for r in rows if r["pwm_heldout_pp"] is not None and not r["pwm_computed"]]
    lines += ["", f"median |total-mass error| {100 * np.nanmedian(err):.1f} % over {len(rows)} rides "
                  f"(target ≤ 10 %; a ride without an estimate counts as 100 %); truth inside the 95 % interval on {inside}/{len(rows)} "
                  f"(target ≥ 9 in 10)",
              f"held-out PWM within 3 points RMS on {sum(p <= 3.0 for p in pwm)}/{len(pwm)} rides "
              f"with another ride of the same wheel carrying measured PWM (app-computed PWM left out)"]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-boot", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"{DATA}: absent; the study needs the shared real rides", file=sys.stderr)
        return 2
    warnings.simplefilter("ignore")
    rows = study(args.n_boot, args.seed)
    print(table(rows))
    if args.json:
        write_json(args.json, {"rides": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
