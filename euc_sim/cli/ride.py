"""``euc-sim ride LOG.csv [--compare OTHER.csv] --report DIR --json OUT.json``.

Registered into :func:`euc_sim.cli.app.build_parser` by :func:`add_ride_parser`.
Bad input (a missing or malformed log, an unusable option, an unwritable
output) raises ``ValueError`` or ``OSError``: one line, exit 2.  Outputs are
checked writable before any work and written atomically (:mod:`euc_sim.io`),
the JSON last.
"""

from __future__ import annotations

from euc_sim.cli.common import seed

import argparse
import math
import os
import warnings
from pathlib import Path

__all__ = ["add_ride_parser", "run_ride", "with_found_values", "MIN_BOOT"]

#: Fewest bootstrap replicates the command accepts: effects are accepted on their
#: 95 % interval, and without replicates there is none (nothing would be accepted).
MIN_BOOT = 10


def _assumptions(args: argparse.Namespace):
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.signals import RideAssumptions

    for opt, val in (("--mass", args.mass), ("--radius", args.radius)):
        if val is not None and not (math.isfinite(val) and val > 0):
            raise ValueError(f"{opt} must be a positive number, got {val!r}")
    if not (math.isfinite(args.efficiency) and 0 < args.efficiency <= 1):
        raise ValueError(f"--efficiency must be in (0, 1], got {args.efficiency!r}")
    p = TABLE3
    sources = []
    if args.radius is not None:
        p = p.replace(R=args.radius)
        sources.append(("R", "--radius"))
    if args.mass is not None:
        m = args.mass - p.m0 - p.mw
        if m <= 0:
            raise ValueError(f"--mass is the total of rider and EUC, kg; {args.mass:g} does not "
                             f"exceed the EUC's own {p.m0 + p.mw:g} kg")
        p = p.replace(m=m)
        sources.append(("total_mass", "--mass"))
    return RideAssumptions.from_params(p, efficiency=args.efficiency, sources=tuple(sources))


def with_found_values(assumptions, spec, total_mass: dict):
    """The balance fit's assumptions with the spec's radius and the mass this log gives.

    A value given on the command line stays; otherwise the radius comes from the
    spec and the total mass (with m_eq, eq. 6) from ``total_mass`` (the ride
    JSON's object, found from the log), and only what neither gives keeps Table
    3's default.  ``sources`` says which is which.

    Parameters
    ----------
    assumptions : RideAssumptions
    spec : WheelSpec or None
    total_mass : dict
        The ride JSON's ``total_mass`` (``estimate`` None when not identified).

    Returns
    -------
    RideAssumptions
        A new object.
    """
    import dataclasses

    src = dict(assumptions.sources)
    new = {}
    if "R" not in src and spec is not None and spec.radius is not None:
        new["R"] = spec.radius
        src["R"] = f"spec ({spec.name or 'wheel'}: wheel diameter)"
    m = (total_mass or {}).get("estimate")
    if "total_mass" not in src and m is not None and m > 0:
        eq = (total_mass.get("equivalent_mass") or {}).get("estimate")
        new["total_mass"], new["m_eq"] = m, (eq if eq is not None else m)
        src["total_mass"] = "found from this log's energy balance (total_mass)"
    return dataclasses.replace(assumptions, sources=tuple(src.items()), **new)


def run_ride(log, compare=None, *, report_dir=None, domain: str = "power", assumptions=None,
             n_boot: int = 200, seed: int = 0, simulate: bool = True, jobs: int = 1,
             progress=None, spec=None, calibrate_rider: bool = False,
             rider_weight: float | None = None) -> dict:
    """Everything ``euc-sim ride`` computes; writes the report folder when given.

    Parameters
    ----------
    log, compare : path
        The ride to fit, and optionally the ride to test on.
    report_dir : path, optional
        Folder for ``index.md`` and the figures (``ride_balance.png``,
        ``ride_residuals.png``, ``ride_simulation.png``) and tables.
    domain : {"power", "torque"}
    assumptions : RideAssumptions, optional
    n_boot, seed : int
        Bootstrap replicates and the seed of every random draw.
    simulate : bool
        Run the closed-loop simulator along the tested ride's speed profile.
    jobs : int
        Processes for the nominal and augmented simulations (1 or 2).
    progress : callable, optional
        Called with a short status string at each step (from the simulation's
        worker processes too when it can be pickled).
    spec : WheelSpec, optional
        The wheel's radius, weight and voltage where known
        (:func:`euc_sim.rides.spec.wheel_spec`).
    calibrate_rider : bool
        Add the ``calibrated_rider`` step (:func:`euc_sim.rides.rider_step.calibrated_rider_step`:
        the rider fitted on LOG, minutes of simulation) between the measured law and the drivetrain.
    rider_weight : float, optional
        The rider's declared weight, kg: checked against the log's total mass (``mass_check``).

    Returns
    -------
    dict
        CONTRACT's ``euc-sim ride`` object plus ``windows`` (s, where the
        inertia-only residual of LOG concentrates), ``localisation``,
        ``residual_traces``, ``simulation`` and ``report``.  Files are named
        relative to ``report_dir`` (file names), never by absolute path.
    """
    from euc_sim.rides.analysis import ride_analysis
    from euc_sim.rides.page import residual_windows
    from euc_sim.rides.signals import RideAssumptions

    say = progress or (lambda s: None)
    assumptions = assumptions or RideAssumptions()
    say("finding the total mass and the drivetrain")
    physics = _drivetrain(log, compare, spec, n_boot, seed)   # bad logs fail before any output
    # the spec's radius and the mass this log gives reach the balance fit (Table 3 only where
    # neither the command line, the spec nor the log gives a value)
    assumptions = with_found_values(assumptions, spec, physics[0]["total_mass"])
    an = ride_analysis(log, compare, assumptions=assumptions, domain=domain, n_boot=n_boot,
                       seed=seed, progress=say)
    say("locating the residual")
    rep = dict(an.report)
    rep.update(physics[0])
    rep["notes"] = list(rep["notes"]) + [_mass_grid_note(physics[1])]
    if compare is not None:     # what differs between the two rides: euc_sim.rides.differences
        from euc_sim.rides.differences_report import differences_json
        rep.update(differences_json(rep, physics[1], physics[2], log, compare))
    say("reading the wheel's balance law")
    from euc_sim.rides.controller_report import controller_json, torque_constant
    rep["controller"] = controller_json(log, compare, torque_constant(rep.get("drivetrain")),
                                        n_boot, seed)
    cr = an.cross
    nom, aug = cr.nominal.estimate, cr.augmented.estimate
    traces = [residual_windows(an.sig_fit, nom, aug, domain, Path(log).name, True)]
    if an.sig_test is not None:
        traces.append(residual_windows(an.sig_test, nom, aug, domain, Path(compare).name, False))
    loc = traces[0].localisation
    rep["windows"] = loc["windows"]
    rep["localisation"] = {"residual": f"inertia-only balance residual of {Path(log).name}, "
                                       f"{rep['error_unit']}",
                           "share": loc["share"], "correlations": loc["correlations"]}
    rep["residual_traces"] = [tr.as_json() for tr in traces]
    sim = None
    if simulate:
        from euc_sim.rides.simulate import simulation_obstacle

        why = simulation_obstacle(an.sig_test if an.sig_test is not None else an.sig_fit)
        if why is None:
            sim = _simulate(an, log, compare, seed, jobs, progress, rep, calibrate_rider)
        else:
            warnings.warn(why, stacklevel=2)
            rep["notes"] = list(rep["notes"]) + [why]
    rep["simulation"] = None if sim is None else sim.as_json()
    from euc_sim.rides.verdict import ride_verdict

    rep["verdict"] = ride_verdict(rep)
    # the rider's numbers (summary, mass check, battery health): euc_sim.rides.rider_view
    from euc_sim.rides.rider_view import rider_numbers
    rep.update(rider_numbers(log, rep, spec, rider_weight))
    rep["report"] = None
    if report_dir is not None:          # every file at the end: an interrupted run writes none
        say(f"writing the report to {report_dir}")
        _write_report(rep, an, traces, sim, physics, Path(report_dir))
    return rep


def _mass_grid_note(fit) -> str:
    """How the mass and drivetrain fits treated the log's gaps (their grid is not the balance fit's)."""
    import numpy as np

    from euc_sim.rides.power import MassSettings

    n = len(np.unique(fit.sig.segment))
    return (f"mass and drivetrain fits: gaps up to {MassSettings.max_gap:g} s bridged linearly on "
            f"their {MassSettings.rate:g} Hz grid, longer ones split the ride ({n} piece(s))")


def _step_line(st: dict) -> str:
    """One step's held-out battery-power error and its ratio to the balance fit's, for the terminal."""
    p = st["heldout_rmse"].get("P_W")
    r = st.get("ratio_to_balance")
    return (f"battery-power RMS {p:.0f} W" if p is not None else "no battery-power error") + \
        (f", {r:.2f}x the balance fit's held-out error (target {st['target_ratio']:g}x)" if r else "")


def _rider_steps():
    from euc_sim.rides.rider_step import RIDER_STEPS

    return RIDER_STEPS


def _simulate(an, log, compare, seed: int, jobs: int, progress, rep: dict, calibrate_rider: bool = False):
    """The closed-loop rider along the tested ride, once per modelled step (:mod:`euc_sim.rides.sim_steps`),
    built from the fit ride's results in ``rep``; the second half scored without compare."""
    from euc_sim.rides.sim_steps import STEP_BUILDERS, StepInputs, build_steps, log_channels
    from euc_sim.rides.simulate import ride_params, simulate_ride

    sig = an.sig_test if an.sig_test is not None else an.sig_fit
    ride_path = compare if compare is not None else log
    scored = None
    if an.sig_test is None:          # score the held-out second half only
        t = sig.frame["t"].to_numpy()
        scored = t >= an.cross.test_design.t.min()      # the test half's first row
    cr = an.cross
    steps = build_steps(StepInputs(ride_params(sig.assumptions), cr.nominal.estimate,
                                   cr.augmented.estimate, cr.accepted, rep, log),
                        _rider_steps() if calibrate_rider else STEP_BUILDERS)
    ran = [s.name for s in steps if s.why is None]
    # the steps' battery-power errors are compared with the balance fit's held-out error (in W)
    balance = rep.get("heldout_error_augmented") if rep.get("error_unit") == "W" else None
    if progress is not None:
        progress(f"simulating the rider along {Path(ride_path).name}: steps {', '.join(ran)}, "
                 f"{min(jobs, len(ran))} process(es)")
    return simulate_ride(sig, steps, ride_path, scored=scored, label=Path(ride_path).name, seed=seed,
                         workers=jobs, channels=log_channels(rep, balance), progress=progress)


def _write_report(rep: dict, an, traces, sim, physics, out: Path) -> None:
    """Figures, tables and ``index.md`` into ``out``; ``rep`` gets their file names.

    Everything is first written into a hidden folder inside ``out`` and moved into
    place (``index.md`` last) only once all of it exists: a failure or an
    interruption half-way leaves ``out`` as it was.
    """
    import shutil
    import tempfile

    out.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".ride-report-", dir=out))
    try:
        _write_report_files(rep, an, traces, sim, physics, stage)
        names = sorted((p.name for p in stage.iterdir()), key=lambda n: n == "index.md")
        for name in names:
            os.replace(stage / name, out / name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _write_report_files(rep: dict, an, traces, sim, physics, out: Path) -> None:
    from euc_sim.io import atomic_write
    from euc_sim.rides.analysis import write_balance
    from euc_sim.rides.page import plot_residuals, write_page

    figures = {"cross_ride": write_balance(an, out).name,
               "residuals": plot_residuals(traces, out / "ride_residuals.png").name}
    rep["figure"] = figures["cross_ride"]
    if sim is not None:
        from euc_sim.rides.simulate import plot_ride_simulation

        figures["simulation"] = plot_ride_simulation(sim, out / "ride_simulation.png").name
        atomic_write(out / "ride_simulation.csv",
                     lambda p: sim.table.to_csv(p, index=False, float_format="%.6g"))
        rep["simulation"]["table"] = "ride_simulation.csv"
        rep["simulation"]["figure"] = figures["simulation"]
    figures.update(_drivetrain_figures(physics, out))
    rep["figures"] = dict(figures)
    rep["report"] = write_page(rep, out, figures).name


def _drivetrain(log, compare, spec, n_boot: int, seed: int):
    """Mass, drivetrain, PWM and envelope (:mod:`euc_sim.rides.drivetrain_report`)."""
    from euc_sim.rides.drivetrain_report import drivetrain_report
    from euc_sim.rides.power import MassSettings
    from euc_sim.rides.spec import WheelSpec

    return drivetrain_report(log, spec or WheelSpec(), compare,
                             MassSettings(n_boot=n_boot, seed=seed))


def _drivetrain_figures(physics, out: Path) -> dict:
    """The envelope, PWM and grade figures of the ride page, by key -> file name."""
    from euc_sim.rides.drivetrain_report import plot_envelope, plot_pwm
    from euc_sim.rides.grade import plot_grade

    rep, fit, test = physics
    figs = {}
    if fit.grade is not None:
        figs["grade"] = plot_grade(fit.grade, out / "ride_grade.png",
                                   title=f"{Path(fit.path).name}: the altitude the battery-power "
                                         f"balance implies, against GPS altitude").name
    if "speed" in rep["envelope"]:
        figs["envelope"] = plot_envelope(rep["envelope"], out / "ride_envelope.png").name
    if fit.drivetrain.pwm_coef is not None:
        target = test if test is not None and "pwm" in test.sig.extra else fit
        figs["pwm"] = plot_pwm(target, out / "ride_pwm.png", fit.drivetrain.pwm_coef,
                               title=f"PWM of {Path(target.path).name}, model fitted on "
                                     f"{Path(fit.path).name}").name
    return figs


def _mass_lines(rep: dict) -> list[str]:
    """The console summary of the mass, the drivetrain and the PWM."""
    tm = rep["total_mass"]
    if tm["estimate"] is None:
        lines = [f"  total mass: not identified ({tm['why']})"]
    else:
        ci = tm["ci95"]
        lines = [f"  total mass (rider + wheel): {tm['estimate']:.0f} kg"
                 + (f" 95% [{ci[0]:.0f}, {ci[1]:.0f}]" if ci else "")
                 + (f"  FLAG: {tm['flag']}" if "flag" in tm else "")]
        if tm.get("rider_mass"):
            rm = tm["rider_mass"]
            lines.append(f"  rider (with gear): {rm['estimate']:.0f} kg")
    for name, why in rep["unidentified"].items():
        lines.append(f"  not identified: {name}: {why}")
    if rep.get("pwm") and rep["pwm"].get("heldout_rmse") is not None:
        lines.append(f"  PWM held out: {rep['pwm']['heldout_rmse']:.1f} percentage points RMS")
    if rep.get("differences_sentence"):
        lines.append(f"  compared: {rep['differences_sentence']}")
    return lines


def _progress(msg: str) -> None:
    """Progress line on stderr (module-level: picklable for the simulation's workers)."""
    import sys

    sys.stderr.write(f"ride: {msg} ...\n")     # one write: lines of two workers never mix
    sys.stderr.flush()


def _cmd_ride(args: argparse.Namespace) -> int:
    from euc_sim.cli.common import say
    from euc_sim.io import check_writable, write_json

    if args.domain not in ("power", "torque"):
        raise ValueError(f"--domain must be power or torque, got {args.domain!r}")
    if args.jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {args.jobs}")
    if args.n_boot < MIN_BOOT:
        raise ValueError(f"--n-boot must be at least {MIN_BOOT} (an effect is accepted on its "
                         f"bootstrap interval), got {args.n_boot}")
    if args.calibrate_rider and args.no_simulate:
        raise ValueError("--calibrate-rider adds a step to the simulation: it cannot go with --no-simulate")
    assumptions = _assumptions(args)
    from euc_sim.rides.rider_view import check_rider_weight
    rider_weight = check_rider_weight(args.rider_weight)
    from euc_sim.rides.analysis import check_data
    from euc_sim.rides.spec import wheel_spec

    spec = wheel_spec(args.wheel, radius=args.radius, wheel_mass=args.wheel_mass,
                      battery_voltage=args.battery_voltage)

    for p in [args.log] + ([args.compare] if args.compare else []):
        if not Path(p).is_file():
            raise FileNotFoundError(f"{p}: no such log file")
    # a malformed or too short log fails here, before any output exists
    check_data(args.log, args.compare, assumptions=assumptions, domain=args.domain)
    if args.json:
        check_writable(args.json)
    if args.report:
        out = Path(args.report)
        if out.exists() and not out.is_dir():
            raise NotADirectoryError(f"--report {out}: exists and is not a folder")
        check_writable(out / "index.md")
    rep = run_ride(args.log, args.compare, report_dir=args.report, domain=args.domain,
                   assumptions=assumptions, n_boot=args.n_boot, seed=args.seed,
                   simulate=not args.no_simulate, jobs=args.jobs,
                   progress=None if args.quiet else _progress, spec=spec,
                   calibrate_rider=args.calibrate_rider, rider_weight=rider_weight)
    if args.json:
        if args.report:         # where the named files are, from the JSON's folder
            rep["report_dir"] = Path(os.path.relpath(Path(args.report).resolve(),
                                                     Path(args.json).resolve().parent)).as_posix()
        write_json(args.json, rep)
    u = rep["error_unit"]
    print(("" if rep["verdict"]["battery_power"] else "V·I, NOT battery power: ")
          + f"held-out error ({rep['error_measure']}): inertia-only "
          f"{rep['heldout_error_nominal']:.1f} {u}, augmented {rep['heldout_error_augmented']:.1f} "
          f"{u}, ratio {rep['ratio']:.2f}")
    from euc_sim.rides.verdict import unit_label

    print(f"  verdict: {rep['verdict']['text']}")
    for e in rep["effects"]:
        kind = "named" if e["name"] in rep["verdict"]["named"] else "candidate"
        flag = "" if e["plausible"] else "  IMPLAUSIBLE"
        al = f"  aliases: {', '.join(e['aliases'])}" if e["aliases"] else ""
        print(f"  {kind}: {e['name']} = {e['estimate']:.4g} {unit_label(e['unit'])} "
              f"95% [{e['ci95'][0]:.4g}, {e['ci95'][1]:.4g}]{flag}{al}")
    for line in _mass_lines(rep):
        print(line)
    print(f"  {rep['mass_check']['sentence']}")
    if rep["windows"]:
        print("  windows (s): " + ", ".join(f"{a:.1f}-{b:.1f}" for a, b in rep["windows"][:8])
              + (" ..." if len(rep["windows"]) > 8 else ""))
    sim = rep["simulation"]
    if sim:
        e = sim["errors"]
        from euc_sim.rides.page import falls_sentence

        if sim["scored_rows"]:
            print(f"  simulation along {sim['ride']}: battery-power RMS nominal {e['nominal']['P_W']:.0f} W, "
                  f"augmented {e['augmented']['P_W']:.0f} W (ratio {e['ratio_P']:.2f})")
            for st in sim.get("steps", []):
                print(f"    step {st['step']}: " + (_step_line(st) if st["ran"] else f"not run ({st['why']})"))
        fell = falls_sentence(sim.get("falls", []), sim["scored_rows"])
        if fell:
            print(f"  simulation along {sim['ride']}: {fell}")
    if rep["report"]:
        say(f"ride: report written to {Path(args.report) / rep['report']}")
    return 0


def add_ride_parser(sub) -> None:
    """Register ``ride`` on the subparsers ``sub``."""
    p = sub.add_parser("ride", help="diagnose a real EUC ride log (WheelLog, EUC World, DarknessBot)")
    p.add_argument("log", metavar="LOG.csv", help="ride log to fit")
    p.add_argument("--compare", metavar="OTHER.csv",
                   help="ride to test on (default: fit the first half, test the second)")
    p.add_argument("--report", metavar="DIR", help="write DIR/index.md with figures and tables")
    p.add_argument("--json", metavar="OUT.json", help="write CONTRACT's ride object")
    p.add_argument("--domain", default="power", metavar="power|torque",
                   help="residual in battery power, W (default), or divided by ω, N·m")
    p.add_argument("--mass", type=float, metavar="KG",
                   help="rider + EUC mass, kg (default Table 3: 81)")
    p.add_argument("--radius", type=float, metavar="M",
                   help="wheel radius, m (default 0.2; overrides the spec's diameter)")
    p.add_argument("--wheel", metavar="SPEC.csv",
                   help="the wheel's specification (Field|Data rows: wheel diameter, net weight, "
                        "battery voltage 'Tension')")
    p.add_argument("--rider-weight", type=float, metavar="KG",
                   help="the rider's declared weight with gear, kg: a prior the log's total mass checks "
                        "(never taken as the answer)")
    p.add_argument("--wheel-mass", type=float, metavar="KG",
                   help="the wheel's net weight, kg (overrides the spec)")
    p.add_argument("--battery-voltage", type=float, metavar="V",
                   help="full-charge battery voltage, V (overrides the spec)")
    p.add_argument("--efficiency", type=float, default=0.8, metavar="ETA",
                   help="drivetrain efficiency used only to infer the logged torque from power "
                        "(default 0.8; the balance fit estimates its own)")
    p.add_argument("--n-boot", type=int, default=200, metavar="N", help=f"bootstrap replicates, at least {MIN_BOOT} (default 200)")
    p.add_argument("--seed", type=seed, default=0, metavar="N", help="seed of every random draw (default 0)")
    p.add_argument("--jobs", type=int, default=2, metavar="N",
                   help="processes for the simulation's steps (default 2)")
    p.add_argument("--calibrate-rider", action="store_true",
                   help="add the step 'calibrated_rider': the simulated rider's delay, bandwidth and "
                        "motor noise fitted on LOG (minutes of simulation)")
    p.add_argument("--no-simulate", action="store_true",
                   help="skip the closed-loop simulation along the ride's speed profile")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--verbose", action="store_true", help=argparse.SUPPRESS)   # progress is the default
    p.set_defaults(func=_cmd_ride)
