#!/usr/bin/env python
"""The grade along a shared route: read on one ride, carried to another (docs/route_grade.md).

    nice python studies/route_grade.py [--only SUBSTR] [--out docs/route_grade.md]

Reads ``../shared/data`` (read-only).  For the WheelLog pair both ways (a tuning
figure: its residual correlation per 25 m of route motivated the idea) and every
ordered pair of euc_core rides of one wheel (the untuned check), each run as
``euc-sim ride LOG --compare OTHER`` fits it (energy-balance mass, bootstrap-free
balance fit): the route match (:func:`euc_sim.rides.grids.route.match_routes`),
the decision to carry (:func:`euc_sim.rides.balance.route_grade.carry_decision`),
and the test ride's held-out error of the selected model without and with the fit
ride's grade profile carried.  Progress on the terminal (stderr); the table to
stdout and into ``--out`` (atomically): between its ``<!-- table -->`` and
``<!-- /table -->`` lines when the page has them (the prose around it is kept),
else as a new page.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import sys
import warnings
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
COMMAND = "nice python studies/route_grade.py --out docs/route_grade.md"
BEGIN, END = "<!-- table -->", "<!-- /table -->"
WHEELS = ("v9", "blitz", "master_pro_V2", "mten4", "lynx")


def pairs(root: Path = SHARED) -> list[tuple[str, Path, Path, Path | None]]:
    """(label, fit log, test log, spec) for the WheelLog pair and every same-wheel euc_core pair."""
    wl = root / "wheellog"
    a, b = wl / "2020_05_16_08_02_06.csv", wl / "2020_05_28_07_52_00.csv"
    out = [(f"wheellog {x.stem[5:10]} -> {y.stem[5:10]}", x, y, None) for x, y in ((a, b), (b, a))]
    by_wheel: dict[str, list[Path]] = {}
    for meta in sorted((root / "euc_core").glob("trips/*/*/*/meta.csv")):
        with open(meta, newline="") as fh:
            wheel = next(csv.DictReader(fh))["wheel"]
        by_wheel.setdefault(wheel, []).append(meta.parent / f"{meta.parent.name}.csv")
    for wheel in WHEELS:
        spec = root / "euc_core" / "specs" / f"{wheel}.csv"
        for x in by_wheel.get(wheel, []):
            for y in by_wheel[wheel]:
                if x != y:
                    out.append((f"{wheel}/{x.stem} -> {y.stem}", x, y,
                                spec if spec.exists() else None))
    return out


def one(label: str, fit: Path, test: Path, spec_path: Path | None,
        shifts: tuple = ()) -> dict:
    """Match, decide and carry for one ordered pair; the row of the table."""
    from euc_sim.rides.balance.route_grade import (carried_grade, carry_decision, carry_grade,
                                                  grade_profile, revisit_check)
    from euc_sim.rides.grids.route import match_by_speed, match_routes, route_position
    from euc_sim.rides.pipeline import balance_on_mass
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import read_spec

    spec = read_spec(spec_path) if spec_path else None
    an = balance_on_mass(read_log(fit), read_log(test), spec, n_boot=0, n_boot_mass=10, seed=0).analysis
    cr = an.cross
    pf = route_position(an.sig_fit.raw)
    pt = route_position(an.sig_test.raw, pf.origin)
    match = match_routes(pf, pt)
    by_speed = match_by_speed(pf, pt)
    row = {"label": label, "inertia_only": cr.heldout_nominal, "selected": cr.heldout_augmented,
           "ratio": cr.ratio, "accepted": list(cr.accepted),
           "gps": pf.xy is not None and pt.xy is not None,
           "match": None if match is None else match.method,
           "shared_m": 0.0 if match is None else match.shared_m,
           "share": 0.0 if match is None else match.share,
           "quality": None if match is None else match.quality,
           "offset_m": None if match is None else match.offset_m,
           "speed_match": None if by_speed is None else (by_speed.quality, by_speed.offset_m),
           "carried": False, "why": "the rides do not share a route",
           "with_grade": None, "ratio_with": None, "grade_range": None, "shared_rows": None,
           "revisit": None}
    if match is None:
        return row
    prof = grade_profile(an.sig_fit, cr.fit_design, cr.augmented.estimate, pf)
    rv = revisit_check(an.sig_fit, cr.fit_design, cr.augmented.estimate, pf)
    row["revisit"] = None if rv is None else (rv.shared_m, rv.before, rv.after)
    dec = carry_decision(prof, match, rv)
    carried = carry_grade(an.sig_test, cr.test_design, carried_grade(prof, match))
    with_grade = cr.augmented.rmse_on(carried)
    on = np.isfinite(match.s_fit)[cr.test_design.use]
    rms = lambda r: float(np.sqrt(np.mean(r[on] ** 2)))  # noqa: E731
    row["shared_rows"] = (rms(cr.test_design.residual(cr.nominal.estimate)),
                          rms(cr.test_design.residual(cr.augmented.estimate)),
                          rms(carried.residual(cr.augmented.estimate)))
    row["shifted"] = {}
    for sh in shifts:       # the profile misplaced by sh m along the route (alignment check)
        moved = dataclasses.replace(match, s_fit=match.s_fit + sh * match.direction)
        r = carry_grade(an.sig_test, cr.test_design,
                        carried_grade(prof, moved)).residual(cr.augmented.estimate)
        row["shifted"][sh] = float(np.sqrt(np.mean(r[on] ** 2)))
    row.update(carried=dec.carry, why=dec.why, with_grade=with_grade,
               ratio_with=with_grade / cr.heldout_nominal,
               grade_range=(float(np.nanmin(prof.sin_alpha)), float(np.nanmax(prof.sin_alpha))),
               fit_insample=(prof.rmse_before, prof.rmse_after), on_bound=prof.on_bound)
    return row


def _f(x, fmt: str) -> str:
    return "—" if x is None else format(x, fmt)


def table(rows: list[dict]) -> str:
    """Markdown table of the rows that share a route, then one line naming the others with
    their held-out ratio (nothing is carried there)."""
    apart = [r for r in rows if r["match"] is None]
    rows = [r for r in rows if r["match"] is not None]
    out = ["| pair | GPS on both | match | shared km (share of test ride) | match quality | "
           "offset m | carried | inertia-only W | selected W | ratio | with the carried grade W "
           "| ratio with | on the shared route: inertia-only → selected → with grade W | "
           "sin α range "
           "| fit ride passed twice: km, second pass without → with the first's grade W |",
           "|" + "---|" * 15]
    for r in rows:
        q = ("—" if r["quality"] is None else
             f"r = {r['quality']:.2f}" if r["match"] == "speed" else f"{r['quality']:.1f} m")
        g = ("—" if r["grade_range"] is None else
             f"{r['grade_range'][0]:+.3f} to {r['grade_range'][1]:+.3f}")
        sh = ("—" if r["shared_rows"] is None else
              " → ".join(f"{x:.1f}" for x in r["shared_rows"]))
        rv = ("—" if r["revisit"] is None else
              f"{r['revisit'][0] / 1000:.2f}: {r['revisit'][1]:.1f} → {r['revisit'][2]:.1f}")
        out.append(f"| {r['label']} | {'yes' if r['gps'] else 'no'} | {r['match'] or 'none'} | "
                   f"{r['shared_m'] / 1000:.2f} ({100 * r['share']:.0f} %) | {q} | "
                   f"{_f(r['offset_m'], '.0f')} | "
                   f"{'yes' if r['carried'] else 'no: ' + r['why']} | "
                   f"{r['inertia_only']:.1f} | {r['selected']:.1f} | {r['ratio']:.3f} | "
                   f"{_f(r['with_grade'], '.1f')} | {_f(r['ratio_with'], '.3f')} | {sh} | {g} "
                   f"| {rv} |")
    if apart:
        out += ["", "Pairs that share no route (nothing carried; selected / inertia-only held out): "
                + ", ".join(f"{r['label']} {r['ratio']:.3f}" for r in apart) + "."]
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="only the pairs whose label contains this")
    ap.add_argument("--out", type=Path, default=None, help="write the Markdown table here")
    ap.add_argument("--shifts", action="store_true",
                    help="also print each matched pair's shared-route error with the carried "
                         "profile moved -75 ... +75 m along the route")
    args = ap.parse_args(argv)
    if not SHARED.is_dir():
        print(f"{SHARED}: the shared rides are not there", file=sys.stderr)
        return 2
    rows = []
    todo = [p for p in pairs() if args.only in p[0]]
    for k, p in enumerate(todo, 1):
        print(f"[{k}/{len(todo)}] {p[0]}", file=sys.stderr, flush=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rows.append(one(*p, shifts=(-75, -50, -25, 0, 25, 50, 75) if args.shifts else ()))
        r = rows[-1]
        print(f"    match {r['match']}, shared {r['shared_m']:.0f} m, speed match "
              f"{r['speed_match']}, ratio {r['ratio']:.3f} -> {_f(r['ratio_with'], '.3f')} "
              f"({'carried' if r['carried'] else r['why']}); shared rows {r['shared_rows']}, "
              f"revisit {r['revisit']}", file=sys.stderr, flush=True)
        for sh, e in r.get("shifted", {}).items():
            print(f"    profile moved {sh:+d} m: shared-route error {e:.1f} W", file=sys.stderr)
    text = table(rows)
    print(text)
    if args.out is not None:
        from euc_sim.io import atomic_write

        page = _page(args.out.read_text() if args.out.exists() else "", text)
        atomic_write(args.out, lambda path: Path(path).write_text(page))
    return 0


def _page(old: str, text: str) -> str:
    """``old`` with the block between :data:`BEGIN` and :data:`END` replaced by the table."""
    block = f"{BEGIN}\n`{COMMAND}`\n\n{text}\n{END}"
    if BEGIN in old and END in old:
        head, rest = old.split(BEGIN, 1)
        return head + block + rest.split(END, 1)[1]
    return f"# The road's grade along a shared route\n\n{block}\n"


if __name__ == "__main__":
    raise SystemExit(main())
