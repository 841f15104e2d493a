"""``euc-sim design``: which maneuvers identify h (:func:`euc_sim.identification.design.design`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from euc_sim.cli.common import parse_params, say, seed
from euc_sim.cli.options import bounded, workers
from euc_sim.cli.sim import RIDER_NOISE
from euc_sim.errors import InputError
from euc_sim.identification.design import DESIGN_MANEUVERS, design, design_figure
from euc_sim.io import check_writable, save_figure, write_json
from euc_sim.simulation.effects import names as effect_names

__all__ = ["add_commands"]


def _floats(text: str, option: str) -> list[float]:
    try:
        return [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise InputError(f"{option} expects comma-separated numbers, got {text!r}") from None


def _cmd_design(args: argparse.Namespace) -> int:
    from euc_sim.simulation.runner import check_backend  # deferred: loads multiprocessing, tqdm (0.02 s)

    plot = Path(args.report) / "design.png" if args.report else None
    effects_plot = Path(args.report) / "design_effects.png" if args.report and args.effect else None
    for path in (args.json, plot, effects_plot):
        if path:
            check_writable(path)
    check_backend(args.scheduler, args.workers)
    if args.effect:                             # refuse bad effect settings before the long h study
        from euc_sim.diagnosis.design import parse_effects  # deferred: loads scipy.optimize, tqdm (0.4 s)
        parse_effects(",".join(args.effect))
    res = design([m.strip() for m in args.maneuvers.split(",") if m.strip()], rides=args.rides,
                 duration=args.duration, noise_scales=_floats(args.noise_scales, "--noise-scales"),
                 targets=_floats(args.targets, "--targets"), seed=args.seed, params=parse_params(args.param),
                 rider_noise=args.rider_noise, scheduler=args.scheduler, workers=args.workers,
                 progress=not args.quiet)
    targets = [f"{t:g}" for t in res["targets"]]
    head = f"{'maneuver':<16}{'h sd MC (mm)':>13}{'Fisher (mm)':>12}{'bias (mm)':>10}" + "".join(
        f"{'n for ' + t + ' m':>14}" for t in targets)
    print(f"h = {res['h_true']:g} m, {res['rides']} rides of {res['duration']:g} s per maneuver, "
          f"sensor noise of the paper (0.2 mm, 0.5°)")
    print(head)
    for r in res["maneuvers"]:
        print(f"{r['maneuver']:<16}{r['h_sd'] * 1e3:13.2f}{r['h_sd_fisher'] * 1e3:12.2f}{r['h_bias'] * 1e3:10.2f}"
              + "".join(f"{r['recordings_for'][t]:14d}" for t in targets)
              + ("   flat" if r["maneuver"] in res["flat"] else ""))
    print(res["recommendation"])
    out = {k: v for k, v in res.items() if k != "curves"}
    if args.effect:
        eff = _effects(args, res, effects_plot)
        for row in out["maneuvers"]:
            row["effects"] = eff["by_maneuver"][row["maneuver"]]
        out["effects_design"] = {k: v for k, v in eff.items() if k != "by_maneuver"}
    if args.json:
        write_json(args.json, out)
    if plot:
        save_figure(design_figure(res), plot)
        say(f"design: wrote {plot}")
    return 0


def _effects(args: argparse.Namespace, res: dict, figure: Path | None) -> dict:
    """The catalog effects' part of ``design``: run, print a table, draw the figure into ``figure``."""
    from euc_sim.diagnosis.design import effects_design, effects_design_figure, parse_effects  # deferred: loads scipy.optimize, tqdm (0.4 s)

    eff = effects_design([r["maneuver"] for r in res["maneuvers"]], parse_effects(",".join(args.effect)),
                         rides=args.effect_rides,
                         duration=args.duration, seed=args.seed, params=parse_params(args.param),
                         rider_noise=args.rider_noise, with_torques=args.with_torques,
                         scheduler=args.scheduler, workers=args.workers, progress=not args.quiet)
    print(f"\neffects at their nominal magnitude, {eff['rides']} rides per maneuver, torques "
          f"{'recorded' if eff['with_torques'] else 'not recorded'}: sd of one recording (Monte Carlo / "
          f"covariance), recordings for sd = 10 % of the magnitude, and to name it ({eff['min_t']:g} sd)")
    mans = [r["maneuver"] for r in res["maneuvers"]]
    print(f"{'effect':<24}{'nominal':>20}" + "".join(f"{m:>30}" for m in mans))
    for e, info in eff["effects"].items():
        head = f"{e:<24}{info['nominal']:>9.3g} {info['unit']:<10}"
        if not info["visible"]:
            print(head + "  not visible: " + info["reason"].split(";")[0])
            continue
        cells = []
        for m in mans:
            c = eff["by_maneuver"][m].get(e, {})
            cells.append(f"{c['sd']:.2g}/{c['sd_cov']:.2g} n={c['recordings_for']['0.1']},{c['recordings_to_detect']}"
                         if c.get("sd") is not None else c.get("why", c.get("failed", "-"))[:28])
        print(head + "".join(f"{x:>30}" for x in cells))
    if figure:
        save_figure(effects_design_figure(eff), figure)
        say(f"design: wrote {figure}")
    return eff


def add_commands(sub) -> None:
    """Register ``design`` on the subparsers ``sub``."""
    p = sub.add_parser("design", help="experiment design: how precisely each maneuver identifies h")
    p.add_argument("--maneuvers", default="constant_speed,deceleration,stop_and_go", metavar="A,B,...",
                   help=f"comma-separated, of {', '.join(DESIGN_MANEUVERS)} "
                        "(default constant_speed,deceleration,stop_and_go)")
    p.add_argument("--rides", type=bounded(3, 10_000, integer=True), default=40, metavar="N",
                   help="Monte Carlo rides per maneuver (default 40)")
    p.add_argument("--duration", type=bounded(5.0, 3600.0, unit="s"), default=15.0, metavar="S",
                   help="s per recording, at least 5 for the fit's filters (default 15)")
    p.add_argument("--noise-scales", default="0.5,1,2", metavar="S,...",
                   help="sensor noise as multiples of the paper's 0.2 mm, 0.5°, each in (0, 100] "
                        "(must include 1; default 0.5,1,2)")
    p.add_argument("--targets", default="0.05,0.02,0.01", metavar="SD,...",
                   help="target standard deviations of h, m, each in (0, 1] (default 0.05,0.02,0.01)")
    p.add_argument("--rider-noise", type=RIDER_NOISE, default=3.0, metavar="N·m",
                   help="rider motor noise, N·m (default 3)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="override a Table 3 value (h: the truth)")
    p.add_argument("--seed", type=seed, default=0, metavar="N",
                   help="seed of the rider and sensor noise, a non-negative integer (default 0)")
    p.add_argument("--json", metavar="FILE", help="write the results as JSON (CONTRACT)")
    p.add_argument("--report", metavar="DIR",
                   help="write the figures into DIR: design.png (RMSE(h) curves and h's sd across noise "
                        "levels) and, with --effect, design_effects.png (each effect's sd per maneuver)")
    p.add_argument("--workers", type=workers(), default=None, metavar="N",
                   help="processes (default: all cores; 1: in this process)")
    p.add_argument("--scheduler", default=None, metavar="local|ADDRESS",
                   help="run on Dask: 'local' starts a local cluster, tcp://HOST:PORT uses a running one")
    p.add_argument("--effect", action="append", default=[], metavar="NAME",
                   help="also this catalog effect (repeatable; 'all' for every one): how precisely each "
                        "maneuver measures it, by Monte Carlo with the effect present and by the "
                        f"diagnosis's covariance; NAME one of all, {', '.join(effect_names())}")
    p.add_argument("--effect-rides", type=bounded(3, 10_000, integer=True), default=10, metavar="N",
                   help="Monte Carlo rides per maneuver and effect (default 10)")
    p.add_argument("--with-torques", action="store_true",
                   help="effects: the recordings carry M_d and M_h (default: motion capture only, as the paper)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_design)
