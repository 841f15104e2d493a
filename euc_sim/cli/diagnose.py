"""``euc-sim diagnose`` and ``euc-sim demo`` (:func:`euc_sim.api.demo.run_demo`), registered by :func:`add_commands`."""

from __future__ import annotations

import argparse
import time

from euc_sim import api
from euc_sim.cli.common import parse_params, say, seed
from euc_sim.io import check_writable, write_json

__all__ = ["add_commands"]


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from euc_sim.report.diagnosis import report_paths  # deferred: loads plotly (0.03 s)

    # every output is checked before any work, so a bad path costs no minute of work
    for path in ([args.json] if args.json else []) + (report_paths(args.report) if args.report else []):
        check_writable(path)
    params = parse_params(args.param) if args.param else None
    result = api.diagnose(args.recording, params=params, resimulate=not args.no_resimulate,
                          calibrate=not args.no_calibrate,
                          progress=None if args.quiet else (lambda s: say(f"diagnose: {s} ...")))
    if args.report:      # the report first: a failing report leaves no JSON behind
        page = result.write_report(args.report)
        say(f"diagnose: report written to {page.with_name('index.html')} (plain text: {page.name})")
    if args.json:
        write_json(args.json, result.to_json())
    print(result.summary())
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from euc_sim.api.demo import run_demo  # deferred: loads matplotlib, plotly, tqdm (0.3 s)

    t0 = time.perf_counter()
    page = run_demo(args.out_dir, seed=args.seed, progress=lambda s: say(f"demo: {s}"))
    print(f"demo: done in {time.perf_counter() - t0:.0f} s; open {page}")
    return 0


def add_commands(sub) -> None:
    """Register ``diagnose`` and ``demo`` on the subparsers ``sub``."""
    p = sub.add_parser("diagnose", help="find the physics the nominal model leaves out of a recording")
    p.add_argument("recording", metavar="REC.csv", help="a CONTRACT recording (.csv or .parquet)")
    p.add_argument("--json", metavar="OUT.json", help="write CONTRACT's diagnosis object")
    p.add_argument("--report", metavar="DIR", help="write DIR/index.html (and DIR/index.md, its plain text) with figures")
    p.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="nominal parameter (default: the sidecar's, else Table 3; h is identified)")
    p.add_argument("--no-resimulate", action="store_true",
                   help="skip re-simulating the maneuver with the accepted effects")
    p.add_argument("--no-calibrate", action="store_true",
                   help="on a 3-D ride, skip calibrating lateral_dynamics on a simulated twin of the ride")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr (shown by default)")
    p.set_defaults(func=_cmd_diagnose)

    p = sub.add_parser("demo", help="the main job on embedded defaults: simulate, identify, diagnose")
    p.add_argument("--out-dir", default="euc-sim-demo", metavar="DIR", help="output folder (default ./euc-sim-demo)")
    p.add_argument("--seed", type=seed, default=1, metavar="N", help="seed of every random draw (default 1)")
    p.set_defaults(func=_cmd_demo)
