"""Measured what reading the mass's climb from the distance grade changes: docs/real_rides.md ("One road grade").

    python studies/mass_grade.py [--n-boot 50]
    python studies/mass_grade.py --lowo BEFORE.json AFTER.json
    python studies/mass_grade.py --former-lowo OUT.json [--n-boot 50]

The first form fits every real ride with GPS altitude (``../shared/data/euc_core``) twice at
the code's defaults (speed scale from Doppler, copper loss κF²): with the climb the mass
read before, g·ḣ from a 10 s Savitzky–Golay derivative of GPS altitude in time (and its
energy windows' Δh from a 10 s-smoothed altitude), and with the climb it reads now,
g·v·sin α, sin α from :func:`euc_sim.rides.grids.route.gps_grade` (altitude over 100 m
of road).  It prints, per ride, the total mass, whether the grade term is kept, and β_h/m
on the 4 s window (the grade's coefficient over the a·v coefficient, 1 if the climb is
read right; with the fit's terms plus the grade where selection did not keep it).  The
former reading lives only here, as the baseline.

The third runs ``scripts/tables/real_rides_study.py --lowo-only`` with the former climb put
back (everything else as the code is now) and writes its JSON to OUT.json.

The second form compares two ``scripts/tables/real_rides_study.py --lowo-only --json``
outputs ride by ride (leave-one-wheel-out mass, interval, coverage).
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts" / "tables"))


def _time_climb(log, sig, settings):
    """The former climb: g·ḣ from a 10 s Savitzky–Golay derivative of GPS altitude in time."""
    from euc_sim.rides.grids.power import G
    from euc_sim.rides.grids.ride import GapPolicy
    from euc_sim.rides.grids.signals import ride_grid, sg

    frame, _ = ride_grid(log, GapPolicy(bridge=settings.max_gap, rate=settings.rate))
    alt, seg = frame["gps_alt"].to_numpy(float), frame["segment"].to_numpy()
    climb = G * sg(np.nan_to_num(alt), seg, settings.rate, 10.0, 2, 1)
    climb[~np.isfinite(alt)] = np.nan
    h = np.where(np.isfinite(alt), sg(np.nan_to_num(alt), seg, settings.rate, 10.0, 2), np.nan)
    return replace(sig, climb=climb, raw={**sig.raw, "h": h})


def _beta_ratio(sig, fit, settings, window: float = 4.0) -> float:
    """β_h/m on one energy window, the grade added to the fit's terms if it was not kept."""
    from euc_sim.rides.drive import mass as mm

    lag = int(round(fit.lag * settings.rate))
    c = fit.coef
    force = (c["inertia"], c.get("rolling", 0.0), c.get("drag", 0.0)) \
        if fit.copper_column == "force" else None
    d = mm._design(sig, lag, window, settings, force)
    names = list(c) + ([] if "grade" in c else ["grade"])
    beta = dict(zip(names, mm._solve(d.X(names), d.y, sig.signed)))
    return float(beta["grade"] / beta["inertia"])


def grade_rows(n_boot: int, seed: int = 0) -> list[dict]:
    """Per ride with GPS altitude and signed current: mass, grade kept, β_h/m, both readings."""
    from real_rides_study import rides

    from euc_sim.rides.drive.mass import fit_mass
    from euc_sim.rides.drive.rotating import without_rotating_inertia
    from euc_sim.rides.grids.power import MassSettings, power_signals
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import read_spec

    settings = MassSettings(n_boot=n_boot, seed=seed)
    out = []
    for it in rides():
        log = read_log(it["log"], emit_warnings=False)
        sig = power_signals(log, settings)
        if sig.climb is None or not sig.signed:
            continue
        spec = read_spec(it["spec"])
        truth = it["rider_weight"] + spec.wheel_mass
        row = {"wheel": it["wheel"], "ride": it["ride"], "truth": truth}
        for name, s in (("time", _time_climb(log, sig, settings)), ("distance", sig)):
            fit = fit_mass(log, settings, sig=s)
            m = without_rotating_inertia(fit, spec.wheel_mass)
            row[name] = {"mass": m.estimate, "error": m.estimate / truth - 1.0,
                         "grade_kept": "grade" in fit.coef,
                         "beta_over_m": _beta_ratio(s, fit, settings)}
        print(f"{it['wheel']}/{it['ride']}: {row}", file=sys.stderr)
        out.append(row)
    return out


def grade_table(rows: list[dict]) -> str:
    lines = ["| wheel | ride | truth kg | mass kg (time → distance) | error | grade kept | β_h/m (4 s) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        a, b = r["time"], r["distance"]
        lines.append(f"| {r['wheel']} | {r['ride']} | {r['truth']:.1f} | {a['mass']:.1f} → {b['mass']:.1f} "
                     f"| {100 * a['error']:+.1f} → {100 * b['error']:+.1f} % "
                     f"| {'yes' if a['grade_kept'] else 'no'} → {'yes' if b['grade_kept'] else 'no'} "
                     f"| {a['beta_over_m']:.2f} → {b['beta_over_m']:.2f} |")
    for k in ("time", "distance"):
        q = [r[k]["beta_over_m"] for r in rows]
        lines.append(f"\n{k}: β_h/m median {np.median(q):.2f} (range {min(q):.2f}–{max(q):.2f}); "
                     f"median |error| {100 * np.median([abs(r[k]['error']) for r in rows]):.1f} %")
    return "\n".join(lines)


def former_lowo(out: Path, n_boot: int) -> int:
    """The leave-one-wheel-out study with the former (time-derivative) climb, all else current."""
    import real_rides_study

    from euc_sim.rides.grids import power

    current = power._filtered

    def former(ride, settings):
        sig = current(ride, settings)
        if sig.climb is None:
            return sig
        return _time_climb(power.as_ride_log(ride), sig, settings)

    power._filtered = former
    try:
        return real_rides_study.main(["--n-boot", str(n_boot), "--lowo-only", "--json", str(out)])
    finally:
        power._filtered = current


def lowo_compare(before: dict, after: dict) -> str:
    """Ride-by-ride leave-one-wheel-out masses of two real_rides_study JSON outputs."""
    lines = ["| wheel | ride | truth kg | before kg (95 %) | after kg (95 %) | error before → after | in CI |",
             "|---|---|---|---|---|---|---|"]
    fmt = lambda t: (f"{t['estimate']:.1f} [{t['ci95'][0]:.0f}, {t['ci95'][1]:.0f}]"   # noqa: E731
                     if t["estimate"] is not None else "–")
    for a, b in zip(before["lowo"]["lowo"]["rides"], after["lowo"]["lowo"]["rides"]):
        lines.append(f"| {a['wheel']} | {a['ride']} | {a['truth']:.1f} | {fmt(a)} | {fmt(b)} "
                     f"| {100 * a['error']:+.1f} → {100 * b['error']:+.1f} % "
                     f"| {'yes' if a['inside'] else 'no'} → {'yes' if b['inside'] else 'no'} |")
    for name, r in (("before", before), ("after", after)):
        w = r["lowo"]["lowo"]
        lines.append(f"\n{name}: median |error| {100 * w['median_abs_error']:.2f} %, "
                     f"covered {sum(t['inside'] for t in w['rides'])}/{w['n']}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-boot", type=int, default=50)
    ap.add_argument("--lowo", nargs=2, type=Path, metavar=("BEFORE", "AFTER"))
    ap.add_argument("--former-lowo", type=Path, metavar="OUT")
    args = ap.parse_args(argv)
    if args.former_lowo:
        return former_lowo(args.former_lowo, args.n_boot)
    if args.lowo:
        try:
            before, after = (json.loads(p.read_text()) for p in args.lowo)
        except (OSError, ValueError) as exc:
            print(f"mass_grade: {exc}", file=sys.stderr)
            return 2
        print(lowo_compare(before, after))
        return 0
    from real_rides_study import DATA

    if not DATA.is_dir():
        print(f"{DATA}: absent; the study needs the shared real rides", file=sys.stderr)
        return 2
    warnings.simplefilter("ignore")
    print(grade_table(grade_rows(args.n_boot)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
