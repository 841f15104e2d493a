"""Measured whether the mass should read its climb from the distance grade: docs/real_rides.md ("One road grade").

    python studies/mass_grade.py twin
    python studies/mass_grade.py beta [--n-boot 50] [--lifted]
    python studies/mass_grade.py lowo OUT.json --reading {time,distance} [--lifted] [--n-boot 50]
    python studies/mass_grade.py compare BEFORE.json AFTER.json

The mass (:func:`euc_sim.rides.drive.mass.fit_mass`) reads the climb as g·ḣ from a 10 s
Savitzky–Golay derivative of GPS altitude in time, its energy windows' Δh from a 10 s-smoothed
altitude (``time``).  The balance reads the road's grade sin α from GPS altitude over 100 m of
road (:func:`euc_sim.rides.grids.route.gps_grade`).  This study puts the second reading into the
mass (``distance``): ḣ = v·sin α at the corrected speed, filtered like every channel, and the
windows' Δh its integral (so a window's Δh/T is exactly the window mean of ḣ).

``--lifted`` also leaves out a segment whose GPS speed is logged throughout and never reaches
1 m/s while the wheel reads above 4 m/s (the wheel lifted and spinning free; on the shared
rides only Apex ride 0's 6 s between two logging gaps, at 121 km/h).

- ``twin``: a synthetic 20-minute ride over a known hill (m = 110 kg), GPS altitude with
  0-2 m of slow error; the mass and β_h/m under both readings.
- ``beta``: every real ride with GPS altitude at the code's defaults, both readings: the
  total mass and β_h/m on the 4 s window (the grade's coefficient over the a·v one, 1 if
  the climb is read right; with the fit's terms plus the grade where selection left it out).
- ``lowo``: ``scripts/tables/real_rides_study.py --lowo-only`` under the reading given;
  ``compare``: two of its JSON outputs ride by ride.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts" / "tables"))


def _integral(x: np.ndarray, t: np.ndarray, segment: np.ndarray) -> np.ndarray:
    """∫x dt from each segment's start (trapezoid rule)."""
    step = 0.5 * (x + np.roll(x, 1)) * np.diff(t, prepend=t[0])
    step[np.r_[True, segment[1:] != segment[:-1]]] = 0.0
    out = np.empty_like(x)
    for s in np.unique(segment):
        out[segment == s] = np.cumsum(step[segment == s])
    return out


def _grid(log, settings):
    from euc_sim.rides.source.gaps import GapPolicy
    from euc_sim.rides.grids.signals import ride_grid

    return ride_grid(log, GapPolicy(bridge=settings.max_gap, rate=settings.rate))[0]


def distance_climb(log, sig, settings):
    """``sig`` with the climb read from the distance grade (ḣ = v·sin α) and Δh its integral."""
    import pandas as pd

    from euc_sim.rides.grids.power import G
    from euc_sim.rides.grids.route import gps_grade
    from euc_sim.rides.grids.signals import sg

    frame = _grid(log, settings)
    v = sig.raw["v"]
    hdot = v * gps_grade(pd.DataFrame({"t": sig.t, "v": v, "gps_alt": frame["gps_alt"].to_numpy(float)}))
    climb = G * sg(hdot, sig.segment, settings.rate, settings.window, 2, 0)
    return replace(sig, climb=climb, raw={**sig.raw, "h": _integral(hdot, sig.t, sig.segment)})


def lifted(frame, v_still: float = 1.0, v_wheel: float = 4.0) -> np.ndarray:
    """Rows of segments where GPS speed (logged throughout) stays below ``v_still`` m/s while
    the wheel reads above ``v_wheel`` m/s: a lifted wheel spinning free."""
    out = np.zeros(len(frame), bool)
    if "gps_speed" not in frame:
        return out
    seg = frame["segment"].to_numpy()
    v, g = frame["v"].to_numpy(float), frame["gps_speed"].to_numpy(float)
    for s in np.unique(seg):
        i = seg == s
        if np.isfinite(g[i]).all() and np.max(g[i]) < v_still and np.nanmax(v[i]) > v_wheel:
            out[i] = True
    return out


@contextmanager
def patched(reading: str, drop_lifted: bool):
    """The mass's signals under ``reading`` (and without lifted-wheel segments), while inside."""
    from euc_sim.rides.grids import power

    current, grid = power._filtered, power.ride_grid

    def no_lift(ride, policy):
        frame, notes = grid(ride, policy)
        return frame.assign(v=np.where(lifted(frame), np.nan, frame["v"])), notes

    def filtered(ride, settings):
        sig = current(ride, settings)
        if reading == "time" or sig.climb is None:
            return sig
        return distance_climb(ride, sig, settings)

    power._filtered = filtered
    if drop_lifted:
        power.ride_grid = no_lift
    try:
        yield
    finally:
        power._filtered, power.ride_grid = current, grid


def beta_ratio(sig, fit, settings, window: float = 4.0) -> float:
    """β_h/m on one energy window, the grade added to the fit's terms if it was not kept."""
    from euc_sim.rides.drive import mass as mm

    c = fit.coef
    force = (c["inertia"], c.get("rolling", 0.0), c.get("drag", 0.0)) \
        if fit.copper_column == "force" else None
    d = mm._design(sig, int(round(fit.lag * settings.rate)), window, settings, force)
    names = list(c) + ([] if "grade" in c else ["grade"])
    beta = dict(zip(names, mm._solve(d.X(names), d.y, sig.signed)))
    return float(beta["grade"] / beta["inertia"])


def _fit_both(log, settings, truth=None, wheel_mass=None) -> dict:
    """Mass and β_h/m of ``log`` under both readings."""
    from euc_sim.rides.drive.mass import fit_mass
    from euc_sim.rides.drive.rotating import without_rotating_inertia
    from euc_sim.rides.grids.power import power_signals

    out = {}
    for reading in ("time", "distance"):
        with patched(reading, drop_lifted=False):
            sig = power_signals(log, settings)
        fit = fit_mass(log, settings, sig=sig)
        m = without_rotating_inertia(fit, wheel_mass) if wheel_mass else fit
        out[reading] = {"mass": m.estimate, "grade_kept": "grade" in fit.coef,
                        "beta_over_m": beta_ratio(sig, fit, settings),
                        "error": m.estimate / truth - 1.0 if truth else float("nan")}
    return out


def _hill_log(alt_sd: float, seed: int = 3, m: float = 110.0, duration: float = 1200.0):
    """A 5 Hz EUC World ride over a known hill: battery power from the energy balance,
    GPS altitude at 1 Hz with slow (10 s) errors of ``alt_sd`` m, in 0.1 m steps."""
    import pandas as pd

    from euc_sim.rides.grids.route import distance_along
    from euc_sim.rides.source.ride import Ride

    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 0.2)
    ph = rng.uniform(0, 2 * np.pi, 3)
    v = (6.0 + 2.0 * np.sin(2 * np.pi * t / 90 + ph[0]) + np.sin(2 * np.pi * t / 23 + ph[1])
         + 0.5 * np.sin(2 * np.pi * t / 7 + ph[2])) * np.clip(t / 20, 0, 1) * np.clip((duration - t) / 20, 0, 1)
    s = distance_along(t, v)
    w1, w2 = 2 * np.pi / 700.0, 2 * np.pi / 260.0
    grade = 0.05 * np.sin(w1 * s) + 0.02 * np.sin(w2 * s + 1.0)
    alt = 40.0 - 0.05 / w1 * np.cos(w1 * s) - 0.02 / w2 * np.cos(w2 * s + 1.0)
    P = 30.0 + m * np.gradient(v, t) * v + 0.02 * m * 9.81 * v + m * 9.81 * v * grade \
        + rng.normal(0.0, 40.0, t.size)
    from scipy.signal import lfilter

    rho = math.exp(-0.2 / 10.0)
    err = lfilter([1.0], [1.0, -rho], rng.normal(0, alt_sd * math.sqrt(1 - rho ** 2), t.size))
    data = pd.DataFrame({"t": t, "v": v, "voltage": np.full_like(t, 84.0), "current": P / 84.0,
                         "gps_alt": np.round((alt + err)[np.arange(t.size) // 5 * 5], 1)})
    return Ride(path="hill.csv", layout="eucworld", variant="", data=data,
                start=pd.Timestamp("2026-01-01"), absent=(), warnings=(), n_rows_read=t.size,
                n_rows_merged=0)


def twin() -> str:
    from euc_sim.rides.grids.power import MassSettings

    lines = ["| GPS altitude error m | mass kg, time → distance (truth 110) | β_h/m, time → distance |",
             "|---|---|---|"]
    for sd in (0.0, 0.5, 1.0, 2.0):
        r = _fit_both(_hill_log(sd), MassSettings(n_boot=10))
        a, b = r["time"], r["distance"]
        lines.append(f"| {sd:g} | {a['mass']:.1f} → {b['mass']:.1f} | {a['beta_over_m']:.2f} → "
                     f"{b['beta_over_m']:.2f} |")
    return "\n".join(lines)


def beta_rows(n_boot: int, drop_lifted: bool) -> list[dict]:
    """Per real ride with GPS altitude and signed current: mass and β_h/m, both readings."""
    from real_rides_study import rides

    from euc_sim.rides.grids.power import MassSettings, power_signals
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import read_spec

    settings = MassSettings(n_boot=n_boot)
    out = []
    with patched("time", drop_lifted):
        for it in rides():
            log = read_log(it["log"], emit_warnings=False)
            sig = power_signals(log, settings)
            if sig.climb is None or not sig.signed:
                continue
            spec = read_spec(it["spec"])
            truth = it["rider_weight"] + spec.wheel_mass
            out.append({"wheel": it["wheel"], "ride": it["ride"], "truth": truth,
                        **_fit_both(log, settings, truth, spec.wheel_mass)})
            print(f"{it['wheel']}/{it['ride']} done", file=sys.stderr)
    return out


def beta_table(rows: list[dict]) -> str:
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
        lines.append(f"\n{k}: β_h/m median {np.median(q):.2f} (range {min(q):.2f}–{max(q):.2f})")
    return "\n".join(lines)


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
        err = [abs(t["error"]) for t in w["rides"]]
        lines.append(f"\n{name}: median |error| {100 * w['median_abs_error']:.2f} % (mean "
                     f"{100 * np.mean(err):.2f} %), covered {sum(t['inside'] for t in w['rides'])}/{w['n']}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("twin")
    b = sub.add_parser("beta")
    b.add_argument("--n-boot", type=int, default=50)
    b.add_argument("--lifted", action="store_true")
    lo = sub.add_parser("lowo")
    lo.add_argument("out", type=Path)
    lo.add_argument("--reading", choices=("time", "distance"), required=True)
    lo.add_argument("--lifted", action="store_true")
    lo.add_argument("--n-boot", type=int, default=50)
    c = sub.add_parser("compare")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    if args.cmd == "twin":
        print(twin())
        return 0
    if args.cmd == "compare":
        try:
            before, after = (json.loads(p.read_text()) for p in (args.before, args.after))
        except (OSError, ValueError) as exc:
            print(f"mass_grade: {exc}", file=sys.stderr)
            return 2
        print(lowo_compare(before, after))
        return 0
    import real_rides_study

    if not real_rides_study.DATA.is_dir():
        print(f"{real_rides_study.DATA}: absent; the study needs the shared real rides", file=sys.stderr)
        return 2
    if args.cmd == "beta":
        print(beta_table(beta_rows(args.n_boot, args.lifted)))
        return 0
    with patched(args.reading, args.lifted):
        return real_rides_study.main(["--n-boot", str(args.n_boot), "--lowo-only", "--json", str(args.out)])


if __name__ == "__main__":
    sys.exit(main())
