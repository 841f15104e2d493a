"""``euc-sim ride LOG.csv [--compare OTHER.csv] --report DIR --json OUT.json``.

Registered into :func:`euc_sim.cli.app.build_parser` by :func:`add_ride_parser`.
Bad input (a missing or malformed log, an unusable option, an unwritable
output) raises ``ValueError`` or ``OSError``: one line, exit 2.  Outputs are
checked writable before any work and written atomically (:mod:`euc_sim.io`),
the JSON last.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from euc_sim.cli.common import check_report_folder, say, seed
from euc_sim.cli.options import bounded, deprecated, one_of, workers
from euc_sim.errors import InputError
from euc_sim.io import check_writable, write_json
from euc_sim.model.parameters import PLAUSIBLE, TABLE3
from euc_sim.rides.pipeline import MIN_BOOT, ride_pipeline
from euc_sim.rides.source.sanity import SPEC_RANGE, TOTAL_MASS_RANGE
from euc_sim.rides.source.spec import SpecError, log_contradictions, wheel_spec
from euc_sim.rides.summary.rider_view import RIDER_WEIGHT, check_rider_weight

__all__ = ["add_ride_parser", "MIN_BOOT"]


def _assumptions(args: argparse.Namespace):
    """The ride's assumptions from ``--radius``, ``--mass`` and ``--efficiency`` (each already
    within its bound, declared with the option)."""
    from euc_sim.rides.grids.signals import RideAssumptions  # deferred: loads scipy (1.1 s)

    p = TABLE3
    sources = []
    if args.radius is not None:
        p = p.replace(R=args.radius)
        sources.append(("R", "--radius"))
    if args.mass is not None:
        m = args.mass - p.m0 - p.mw
        if m <= 0:
            raise InputError(f"--mass is the total of rider and EUC, kg; {args.mass:g} does not "
                             f"exceed the EUC's own {p.m0 + p.mw:g} kg")
        p = p.replace(m=m)
        sources.append(("total_mass", "--mass"))
    return RideAssumptions.from_params(p, efficiency=args.efficiency, sources=tuple(sources))


def _progress(msg: str) -> None:
    """Progress line on stderr (module-level: picklable for the simulation's workers)."""
    sys.stderr.write(f"ride: {msg} ...\n")     # one write: lines of two workers never mix
    sys.stderr.flush()


def _cmd_ride(args: argparse.Namespace) -> int:
    if args.domain not in ("power", "torque"):
        raise InputError(f"--domain must be power or torque, got {args.domain!r}")
    if args.n_boot < MIN_BOOT:
        raise InputError(f"--n-boot must be at least {MIN_BOOT} (an effect is accepted on its "
                         f"bootstrap interval), got {args.n_boot}")
    if args.calibrate_rider and args.simulate is False:
        raise InputError("--calibrate-rider adds a step to the simulated replay: it cannot go with --no-simulate")
    # with --compare the replay runs unless refused: CONTRACT's compared JSON carries its "simulation"
    simulate = bool(args.calibrate_rider or (args.compare is not None if args.simulate is None else args.simulate))
    assumptions = _assumptions(args)
    weights = args.rider_weight or []
    if len(weights) > 2:
        raise InputError(f"--rider-weight: at most twice (LOG's rider, then OTHER's), got {len(weights)} values")
    if len(weights) == 2 and not args.compare:
        raise InputError("--rider-weight given twice: the second is OTHER's rider, which needs --compare OTHER.csv")
    rider_weight = check_rider_weight(weights[0]) if weights else None
    compare_rider_weight = check_rider_weight(weights[-1]) if weights and args.compare else None
    from euc_sim.rides.balance.analysis import check_data  # deferred: loads scipy (1.1 s)

    spec = wheel_spec(args.wheel, radius=args.radius, wheel_mass=args.wheel_mass,
                      battery_voltage=args.battery_voltage)

    from euc_sim.rides.source.logs import read_log  # deferred: loads euc_sim.rides.source.bounds (0.01 s)

    # each log is parsed once, here; a malformed or too short log fails before any output exists
    ride = read_log(args.log, emit_warnings=False)
    other = read_log(args.compare, emit_warnings=False) if args.compare else None
    if args.wheel:              # a spec whose voltage class the log cannot have is refused here

        for p, r in ((args.log, ride), (args.compare, other)):
            try:
                r is None or log_contradictions(spec, r.data)
            except SpecError as exc:
                raise SpecError(f"{p}: {exc} (--wheel {args.wheel})") from None
    check_data(ride, other, assumptions=assumptions,
               domain=args.domain)
    if args.json:
        check_writable(args.json)
    if args.report:
        check_report_folder(args.report, ("index.md", "index.html"))
    for r in (ride, other):         # each repair of the reader, one line, whatever --quiet
        for line in r.repairs if r else ():
            say(f"euc-sim ride: note: {r.name}: {line}")
    from euc_sim.rides.render.contract import ride_json  # deferred: loads pandas, scipy (1.2 s)
    from euc_sim.rides.render.report_files import write_report  # deferred: loads pandas, scipy (1.2 s)

    res = ride_pipeline(ride, other, domain=args.domain, assumptions=assumptions, n_boot=args.n_boot,
                        seed=args.seed, simulate=simulate, jobs=args.workers,
                        progress=None if args.quiet else _progress, spec=spec,
                        calibrate_rider=args.calibrate_rider, rider_weight=rider_weight,
                        compare_rider_weight=compare_rider_weight)
    files = where = None
    if args.report:             # every file at the end: an interrupted run writes none
        if not args.quiet:
            _progress(f"writing the report to {args.report}")
        files = write_report(res, Path(args.report))
        if args.json:           # where the named files are, from the JSON's folder
            where = Path(os.path.relpath(Path(args.report).resolve(),
                                         Path(args.json).resolve().parent)).as_posix()
    rep = ride_json(res, files, where)
    if args.json:
        write_json(args.json, rep)
    from euc_sim.rides.render.terminal import summary_lines  # deferred: loads pandas, scipy, plotly (1.5 s)

    for line in summary_lines(res):
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
    p.add_argument("--domain", default="power", metavar=one_of(("power", "torque")),
                   help="residual in battery power, W (default), or divided by ω, N·m")

    p.add_argument("--mass", type=bounded(*TOTAL_MASS_RANGE, unit="kg"), metavar="KG",
                   help="rider + EUC mass, kg (default Table 3: 81)")
    p.add_argument("--radius", type=bounded(*PLAUSIBLE["R"], unit="m"), metavar="M",
                   help="wheel radius, m (default 0.2; overrides the spec's diameter)")
    p.add_argument("--wheel", metavar="NAME|SPEC.csv",
                   help="the wheel: a shipped wheel's name (v9, lynx, apex, aero, blitz, mten4, "
                        "'master pro v2', 's22 pro', z10) or a specification file (Field|Data rows: "
                        "wheel diameter, net weight, battery voltage 'Tension', ...)")
    p.add_argument("--rider-weight", type=bounded(*RIDER_WEIGHT, unit="kg"), metavar="KG", action="append",
                   help="the rider's declared weight with gear, kg: a prior the log's total mass checks "
                        "(never taken as the answer); with --compare it holds for both rides, or give it "
                        "twice: LOG's rider, then OTHER's")
    p.add_argument("--wheel-mass", type=bounded(*SPEC_RANGE["wheel_mass"][:2], unit="kg"), metavar="KG",
                   help="the wheel's net weight, kg (overrides the spec)")
    p.add_argument("--battery-voltage", type=bounded(*SPEC_RANGE["battery_voltage"][:2], unit="V"),
                   metavar="V",
                   help="full-charge battery voltage, V (overrides the spec)")
    p.add_argument("--efficiency", type=bounded(0.1, 1.0), default=0.8, metavar="ETA",
                   help="drivetrain efficiency used only to infer a logged torque from battery "
                        "power (--domain torque, the simulation's torque column; default 0.8); "
                        "the balance fit has no efficiency")
    p.add_argument("--n-boot", type=bounded(MIN_BOOT, 100_000, integer=True), default=200, metavar="N",
                   help=f"bootstrap replicates, at least {MIN_BOOT} (default 200, at most 100000)")
    p.add_argument("--seed", type=seed, default=0, metavar="N", help="seed of every random draw (default 0)")
    p.add_argument("--workers", type=workers(), default=2, metavar="N",
                   help="threads for the simulation's steps (default 2)")
    deprecated(p, "--jobs", "--workers")
    p.add_argument("--calibrate-rider", action="store_true",
                   help="add the step 'calibrated_rider': the simulated rider's delay, bandwidth and "
                        "motor noise fitted on LOG (minutes of simulation)")
    p.add_argument("--simulate", action=argparse.BooleanOptionalAction, default=None,
                   help="replay the ride: the closed-loop MuJoCo rider along the tested ride's speed "
                        "profile, once per modelled step (minutes; by default run with --compare only, "
                        "--no-simulate skips it; --calibrate-rider turns it on)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    deprecated(p, "--verbose", "--quiet", nargs=0, dest="verbose", default=False,
               note="progress is shown unless --quiet")
    p.set_defaults(func=_cmd_ride)
