"""Does the simulated rider fall on the real logs?  Every log's profile ridden as the ride page does.

Usage (from the repository root, with ``../shared`` beside it)::

    python scripts/tables/ride_falls.py [--workers 2] [--only v9/0 ...] [--out /tmp/ride_falls]
                                 [--n-boot 50] [--runs nominal augmented firmware]
                                 [--track-iterations 1]

For each of the 21 shared real logs (``../shared/data/euc_core/trips/*/*/N/N.csv`` with the
wheel's spec where there is one, and ``../shared/data/wheellog/*.csv``) it runs what
``euc-sim ride LOG --wheel SPEC`` runs before simulating (the drivetrain and mass fit, the
balance fit of :func:`euc_sim.rides.balance.analysis.ride_analysis`, the measured balance law of
:func:`euc_sim.rides.law.controller_report.controller_fit`) and then rides the log's speed
profile (:func:`euc_sim.rides.grids.profile.speed_profile`) with
:func:`euc_sim.rides.sim.tracking.simulate_profile`:

``nominal``     the paper's model, no injected effect;
``augmented``   the accepted balance effects injected as physics (:func:`effects_to_inject`);
``firmware``    the nominal run with the wheel's measured law as the motor controller
                (:func:`euc_sim.controllers.firmware.firmware_motor`), where the log gives one.

Output under ``--out``: ``logs/NAME.json`` as each log is done, then ``falls.csv`` (one row per log and run: ride seconds, fell, time,
cause, the profile's speed and acceleration at the fall, the profile's largest |a|, the
wall time), ``falls.json`` and a one-line summary per log on stdout.  Progress on stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data"
RUNS = ("nominal", "augmented", "firmware")
WHEELLOG = ("2020_05_16_08_02_06.csv", "2020_05_28_07_52_00.csv", "wheellog_android_log_test1.csv")


def logs() -> list[tuple[str, Path, Path | None]]:
    """(name, log, spec or None) of the 21 shared logs."""
    out = []
    for csv in sorted((SHARED / "euc_core" / "trips").glob("*/*/*/*.csv")):
        if csv.name == "meta.csv":
            continue
        model = csv.parents[1].name
        spec = SHARED / "euc_core" / "specs" / f"{model}.csv"
        out.append((f"{model}/{csv.parent.name}", csv, spec if spec.is_file() else None))
    out += [(f"wheellog/{Path(n).stem}", SHARED / "wheellog" / n, None) for n in WHEELLOG]
    return out


def _profile_at(t, v, a, when: float) -> tuple[float, float]:
    import numpy as np

    i = int(np.argmin(np.abs(t - when)))
    return float(v[i]), float(a[i])


def ride_log(job: tuple) -> list[dict]:
    """Every run of one log (a worker): rows of ``falls.csv``."""
    name, log, spec_path, n_boot, seed, wanted, iterations, out = job
    rows = _ride_log(name, log, spec_path, n_boot, seed, wanted, iterations)
    part = Path(out) / "logs" / f"{name.replace('/', '_')}.json"
    part.parent.mkdir(parents=True, exist_ok=True)
    part.write_text(json.dumps(rows, indent=1, default=str))    # kept if the study is cut short
    return rows


def _ride_log(name, log, spec_path, n_boot, seed, wanted, iterations) -> list[dict]:
    """:func:`ride_log` without writing."""
    firmware = "firmware" in wanted
    import numpy as np

    from euc_sim.rides.grids.profile import speed_profile
    from euc_sim.rides.law.controller_report import controller_fit, firmware_terms, torque_constant
    from euc_sim.rides.pipeline import balance_on_mass
    from euc_sim.rides.sim.simulate import effects_to_inject, ride_params, simulation_obstacle
    from euc_sim.rides.sim.tracking import simulate_profile
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import wheel_spec

    spec = wheel_spec(spec_path)
    log = read_log(log, emit_warnings=False)
    fitted = balance_on_mass(log, None, spec, n_boot=n_boot, seed=seed)
    physics, an = fitted.physics, fitted.analysis
    sig = an.sig_fit
    why = simulation_obstacle(sig)
    base = {"log": name, "ride_s": float("nan")}
    if why is not None:
        return [dict(base, run="-", fell=None, cause=why)]
    prof = speed_profile(log, sig.rate, sig.window, sig.polyorder, total_mass=sig.assumptions.total_mass)
    t, v = prof["t"].to_numpy(), prof["v"].to_numpy()
    a = np.gradient(v, t)
    base = {"log": name, "ride_s": float(t[-1] - t[0]), "v_max": float(v.max()),
            "a_max_profile": float(np.abs(a).max())}
    params = ride_params(sig.assumptions)
    eff, _ = effects_to_inject(an.cross.augmented.estimate, an.cross.accepted)
    runs = [("nominal", {}, None), ("augmented", eff, None)]
    if firmware:
        from euc_sim.controllers.firmware import FirmwareError, firmware_motor

        law = controller_fit(log, None, torque_constant(physics.terms), n_boot, seed)
        try:
            motor, _ = firmware_motor(firmware_terms(law), params)
            runs.append(("firmware", {}, motor))
        except FirmwareError as exc:
            base["firmware"] = str(exc)
    rows = []
    for run, effects, motor in [r for r in runs if r[0] in wanted]:
        print(f"ride_falls: {name} {run}: {base['ride_s']:.0f} s of ride", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        res = simulate_profile(t, v, params, effects, seed=seed, track_iterations=iterations,
                               motor=motor)
        wall = time.perf_counter() - t0
        row = dict(base, run=run, effects=json.dumps(effects), wall_s=wall, fell=bool(res.falls))
        if res.falls:
            f = res.falls[0]
            row.update(t_fall=f["t"], cause=f["cause"])
            row["v_at_fall"], row["a_at_fall"] = _profile_at(t, v, a, f["t"])
        later = [n for n in res.notes if "rider fell" in n and "correction" in n]
        if later:
            row["correction_fell"] = later[0]
        rows.append(row)
        print(f"ride_falls: {name} {run}: {'FELL at %.1f s' % row['t_fall'] if row['fell'] else 'rode'} "
              f"({wall:.0f} s wall)", file=sys.stderr, flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--only", nargs="*", help="log names (e.g. v9/0 wheellog/2020_05_16_08_02_06)")
    ap.add_argument("--out", default="/tmp/ride_falls")
    ap.add_argument("--n-boot", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--track-iterations", type=int, default=1)
    ap.add_argument("--runs", nargs="+", default=list(RUNS), choices=RUNS)
    args = ap.parse_args(argv)
    if not (SHARED / "euc_core").is_dir():
        print(f"ride_falls: {SHARED / 'euc_core'} not found", file=sys.stderr)
        return 2
    if args.workers < 1:
        print(f"ride_falls: --workers must be at least 1, got {args.workers}", file=sys.stderr)
        return 2
    chosen = logs()
    if args.only:
        unknown = set(args.only) - {n for n, _, _ in chosen}
        if unknown:
            print(f"ride_falls: unknown log(s) {sorted(unknown)}; known: {[n for n, _, _ in chosen]}",
                  file=sys.stderr)
            return 2
        chosen = [c for c in chosen if c[0] in args.only]
    import pandas as pd

    from euc_sim.simulation.runner import run_tasks

    chosen.sort(key=lambda c: c[1].stat().st_size)          # the short logs first
    jobs = [(n, (n, log, spec, args.n_boot, args.seed, tuple(args.runs), args.track_iterations, args.out))
            for n, log, spec in chosen]
    done: list[str] = []

    def note(name, _rows) -> None:
        done.append(name)
        print(f"ride_falls: log {len(done)}/{len(jobs)} done ({name})", file=sys.stderr, flush=True)

    rep = run_tasks(ride_log, jobs, workers=args.workers, progress=False, on_result=note)
    if rep.failed:
        print("ride_falls: failed: " + "; ".join(f"{n}: {why}" for n, why in rep.failed.items()), file=sys.stderr)
        return 1
    rows = [r for rs in rep.results.values() for r in rs]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = pd.DataFrame(rows)
    table.to_csv(out / "falls.csv", index=False, float_format="%.4g")
    (out / "falls.json").write_text(json.dumps(rows, indent=1, default=str))
    for name in dict.fromkeys(table["log"]):
        sub = table[table["log"] == name]
        parts = [f"{r.run}: " + (f"FELL t={r.t_fall:.1f}s v={r.v_at_fall:.1f} a={r.a_at_fall:+.2f} ({r.cause})"
                                 if r.fell is True else "rode" if r.fell is False else str(r.cause))
                 for r in sub.itertuples()]
        print(f"{name:32s} {sub['ride_s'].iloc[0]:6.0f} s  " + "; ".join(parts))
    n_fell = int((table["fell"] == True).sum())  # noqa: E712 - None for skipped logs
    print(f"{n_fell} fall(s) in {len(table)} run(s) of {len(chosen)} log(s); table: {out / 'falls.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
