"""``euc-sim ride LOG.csv [--compare OTHER.csv] --report DIR --json OUT.json``.

The options are :func:`euc_sim.rides.request.ride_request`'s; bad input is one line, exit 2.
Outputs are checked writable before any work and written atomically, the JSON last.
"""

from __future__ import annotations

import argparse
import inspect
import os
import sys
from pathlib import Path

from euc_sim.api.functions import analyse_request
from euc_sim.cli.common import check_report_folder, say, seed
from euc_sim.cli.options import bounded, one_of, workers
from euc_sim.io import check_writable, write_json
from euc_sim.rides.request import BOUNDS, DOMAINS, ride_request

__all__ = ["add_ride_parser"]


def _progress(msg: str) -> None:
    """Progress line on stderr (module-level: picklable for the simulation's workers)."""
    sys.stderr.write(f"ride: {msg} ...\n")     # one write: lines of two workers never mix
    sys.stderr.flush()


def _cmd_ride(args: argparse.Namespace) -> int:
    # each of the request's keywords is an option of the same name: the API's and the command's are one
    req = ride_request(**{k: getattr(args, k) for k in inspect.signature(ride_request).parameters})
    if args.json:
        check_writable(args.json)
    if args.report:
        check_report_folder(args.report, ("index.md", "index.html"))
    for r in (req.log, req.compare):         # each repair of the reader, one line, whatever --quiet
        for line in r.repairs if r else ():
            say(f"euc-sim ride: note: {r.name}: {line}")
    from euc_sim.report.ride.contract import ride_json  # deferred: loads pandas, scipy (1.2 s)

    done = analyse_request(req, args.report, args.workers, None if args.quiet else _progress)
    where = None
    if args.report and args.json:           # where the named files are, from the JSON's folder
        where = Path(os.path.relpath(Path(args.report).resolve(), Path(args.json).resolve().parent)).as_posix()
    rep = ride_json(done.result, done.files, where)
    if args.json:
        write_json(args.json, rep)
    from euc_sim.report.ride.terminal import summary_lines  # deferred: loads pandas, scipy, plotly (1.5 s)

    for line in summary_lines(done.result):
        print(line)
    if rep["report"]:
        say(f"ride: report written to {Path(args.report) / rep['report']}")
    return 0


def add_ride_parser(sub) -> None:
    """Register ``ride`` on the subparsers ``sub``."""
    p = sub.add_parser("ride", help="diagnose a real EUC ride log (WheelLog, EUC World, DarknessBot)")
    p.add_argument("log", metavar="LOG.csv", help="ride log to fit")
    p.add_argument("--compare", metavar="OTHER.csv",
                   help="ride to test on (default: fit the first half, test the second)")
    p.add_argument("--report", metavar="DIR", help="write DIR/index.html (the page; DIR/index.md its plain-text version) with figures and tables")
    p.add_argument("--json", metavar="OUT.json", help="write CONTRACT's ride object")
    p.add_argument("--domain", default="power", metavar=one_of(DOMAINS),
                   help="residual in battery power, W (default), or divided by ω, N·m")

    p.add_argument("--mass", type=bounded(*BOUNDS["mass"], checked=False), metavar="KG",
                   help="rider + EUC mass, kg (default Table 3: 81)")
    p.add_argument("--radius", type=bounded(*BOUNDS["radius"], checked=False), metavar="M",
                   help="wheel radius, m (default 0.2; overrides the spec's diameter)")
    p.add_argument("--wheel", metavar="NAME|SPEC.csv",
                   help="the wheel: a shipped wheel's name (v9, lynx, apex, aero, blitz, mten4, "
                        "'master pro v2', 's22 pro', z10) or a specification file (Field|Data rows: "
                        "wheel diameter, net weight, battery voltage 'Tension', ...)")
    p.add_argument("--rider-weight", type=bounded(*BOUNDS["rider_weight"], checked=False), metavar="KG",
                   action="append",
                   help="the rider's declared weight with gear, kg: a prior the log's total mass checks "
                        "(never taken as the answer); with --compare it holds for both rides, or give it "
                        "twice: LOG's rider, then OTHER's")
    p.add_argument("--wheel-mass", type=bounded(*BOUNDS["wheel_mass"], checked=False), metavar="KG",
                   help="the wheel's net weight, kg (overrides the spec)")
    p.add_argument("--battery-voltage", type=bounded(*BOUNDS["battery_voltage"], checked=False), metavar="V",
                   help="full-charge battery voltage, V (overrides the spec)")
    p.add_argument("--efficiency", type=bounded(*BOUNDS["efficiency"], checked=False), default=0.8, metavar="ETA",
                   help="drivetrain efficiency used only to infer a logged torque from battery "
                        "power (--domain torque, the simulation's torque column; default 0.8); "
                        "the balance fit has no efficiency")
    p.add_argument("--n-boot", type=bounded(*BOUNDS["n_boot"], checked=False), default=200, metavar="N",
                   help="bootstrap replicates (default 200)")
    p.add_argument("--seed", type=seed, default=0, metavar="N", help="seed of every random draw (default 0)")
    p.add_argument("--workers", type=workers(), default=2, metavar="N",
                   help="threads for the simulation's steps (default 2)")
    p.add_argument("--calibrate-rider", action="store_true",
                   help="add the step 'calibrated_rider': the simulated rider's delay, bandwidth and "
                        "motor noise fitted on LOG (minutes of simulation)")
    p.add_argument("--simulate", action=argparse.BooleanOptionalAction, default=None,
                   help="replay the ride: the closed-loop MuJoCo rider along the tested ride's speed "
                        "profile, once per modelled step (minutes; by default run with --compare only, "
                        "--no-simulate skips it; --calibrate-rider turns it on)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(func=_cmd_ride)
