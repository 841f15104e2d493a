"""The ride pipeline: one log (and optionally another) in, one typed result out.

:func:`ride_pipeline` takes each log parsed once (a :class:`~euc_sim.rides.source.ride.Ride`
of :func:`~euc_sim.rides.source.logs.read_log`), then runs the analyses in order on it: mass and drivetrain
(:mod:`euc_sim.rides.drive.drivetrain_report`), the bounded balance fit with its
held-out selection (:mod:`euc_sim.rides.balance.analysis`), the balance law
(:mod:`euc_sim.rides.law.controller_report`), the one parameter set
(:mod:`euc_sim.rides.balance.parameters`), the residual's localisation, the simulated
rider (:mod:`euc_sim.rides.sim.sim_steps`) and the verdict.  It returns a
:class:`RideResult`; the JSON (:attr:`RideResult.report`) and the page
(:func:`write_report`) are renderers at the edge.  ``euc-sim ride``
(:mod:`euc_sim.cli.ride`) parses its arguments and calls it; scripts call it too.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

__all__ = ["RideResult", "BalanceOnMass", "balance_on_mass", "ride_pipeline", "run_ride", "write_report",
           "MIN_BOOT"]

#: Fewest bootstrap replicates the command accepts: effects are accepted on their
#: 95 % interval, and without replicates there is none (nothing would be accepted).
MIN_BOOT = 10
#: ``simulation_why`` (and the page) when the replay was not asked for.
REPLAY_NOT_ASKED = ("not run: a step you ask for (the MuJoCo rider along this ride's speed, one run per "
                    "modelled step, minutes): euc-sim ride LOG.csv --simulate (with --compare it runs "
                    "unless --no-simulate)")


@dataclass
class RideResult:
    """What :func:`ride_pipeline` computed.

    Attributes
    ----------
    report : dict
        CONTRACT's ``euc-sim ride`` object (``parameters``, ``effects``, ``total_mass``,
        ``drivetrain``, ``controller``, ``simulation``, ``verdict``, ...).
    analysis : RideAnalysis
        The balance fit (:mod:`euc_sim.rides.balance.analysis`).
    traces : list
        Residual traces of the fit and test rides (:func:`euc_sim.rides.balance.residual.residual_windows`).
    simulation : object or None
        :func:`euc_sim.rides.sim.simulate.simulate_ride`'s result.
    physics : tuple
        ``(report, fit, test)`` of :func:`euc_sim.rides.drive.drivetrain_report.drivetrain_report`.
    """

    report: dict
    analysis: object
    traces: list
    simulation: object
    physics: tuple


def run_ride(log, compare=None, *, report_dir=None, **kwargs) -> dict:
    """:func:`ride_pipeline`, the report folder written when given; returns the JSON object."""
    res = ride_pipeline(log, compare, **kwargs)
    if report_dir is not None:          # every file at the end: an interrupted run writes none
        if kwargs.get("progress"):
            kwargs["progress"](f"writing the report to {report_dir}")
        write_report(res, Path(report_dir))
    return res.report


@dataclass(frozen=True)
class BalanceOnMass:
    """The first two steps of a ride: the energy balance's mass, then the balance fit given it.

    Attributes
    ----------
    physics : tuple
        ``(report, fit, test)`` of :func:`euc_sim.rides.drive.drivetrain_report.ride_drivetrain`.
    assumptions : RideAssumptions
        The assumptions handed to the balance fit (the log's total mass, the spec's radius).
    analysis : RideAnalysis
        :func:`euc_sim.rides.balance.analysis.ride_analysis`'s result.
    """

    physics: tuple
    assumptions: object
    analysis: object


def balance_on_mass(log, compare=None, spec=None, *, assumptions=None, domain: str = "power",
                    n_boot: int = 200, seed: int = 0, n_boot_mass: int | None = None,
                    progress=None) -> BalanceOnMass:
    """The total mass from the log's energy balance, then the balance fit given it.

    What :func:`ride_pipeline` runs first, for scripts that need only these two fits.

    Parameters
    ----------
    log, compare : Ride
    spec : WheelSpec, optional
    assumptions : RideAssumptions, optional
        Values given on the command line; the spec's radius and the log's mass fill the rest.
    domain : {"power", "torque"}
    n_boot, seed : int
        Bootstrap replicates of the balance fit and the seed of every draw.
    n_boot_mass : int, optional
        Replicates of the mass fit (default ``n_boot``).
    progress : callable, optional

    Returns
    -------
    BalanceOnMass
    """
    from euc_sim.rides.balance.analysis import ride_analysis
    from euc_sim.rides.grids.signals import RideAssumptions, with_found_values
    from euc_sim.rides.drive.drivetrain_report import ride_drivetrain

    say = progress or (lambda s: None)
    say("finding the total mass and the drivetrain")
    physics = ride_drivetrain(log, compare, spec, n_boot if n_boot_mass is None else n_boot_mass, seed)
    # the spec's radius and the mass this log gives reach the balance fit (Table 3 only where
    # neither the command line, the spec nor the log gives a value)
    assumptions = with_found_values(assumptions or RideAssumptions(), spec, physics[0]["total_mass"])
    an = ride_analysis(log, compare, assumptions=assumptions, domain=domain, n_boot=n_boot,
                       seed=seed, progress=progress)
    return BalanceOnMass(physics, assumptions, an)


def ride_pipeline(log, compare=None, *, domain: str = "power", assumptions=None,
                  n_boot: int = 200, seed: int = 0, simulate: bool = False, jobs: int = 1,
                  progress=None, spec=None, calibrate_rider: bool = False,
                  rider_weight: float | None = None, compare_rider_weight: float | None = None) -> RideResult:
    """Everything ``euc-sim ride`` computes, in order, on logs parsed once.

    Parameters
    ----------
    log, compare : Ride
        The ride to fit, and optionally the ride to test on.
    domain : {"power", "torque"}
    assumptions : RideAssumptions, optional
    n_boot, seed : int
        Bootstrap replicates and the seed of every random draw.
    simulate : bool
        Replay the ride: the closed-loop simulator along the tested ride's speed profile
        (minutes; a step the rider asks for, off by default: ``simulation_why`` says so).
    jobs : int
        Threads for the simulation's steps (the results do not depend on it).
    progress : callable, optional
        Called with a short status string at each step.
    spec : WheelSpec, optional
    calibrate_rider : bool
        Add the ``calibrated_rider`` step.
    rider_weight : float, optional
        The rider's declared weight, kg: checked against the log's total mass (``mass_check``).
    compare_rider_weight : float, optional
        The same for the compared ride (``compared.mass_check``).

    Returns
    -------
    RideResult
        ``report`` is CONTRACT's ``euc-sim ride`` object plus ``windows``,
        ``localisation``, ``residual_traces``, ``simulation``, ``report`` (None
        until :func:`write_report`).
    """
    from euc_sim.rides.summary.rider_view import rider_numbers

    say = progress or (lambda s: None)
    # each grid is built once and kept on its ride; bad logs fail in the mass fit, before any output
    fitted = balance_on_mass(log, compare, spec, assumptions=assumptions, domain=domain,
                             n_boot=n_boot, seed=seed, progress=say)
    physics, an = fitted.physics, fitted.analysis
    rep = _one_parameter_set(an, physics, log, compare, n_boot, seed, say)
    if compare is not None:     # what differs between the two rides (rides.compare.differences), each
        # ride's terms from its own energy-balance fit, so both sides are read alike
        from euc_sim.rides.compare.differences_report import differences_json

        rep.update(differences_json(physics[0], physics[1], physics[2], log, compare))
    say("locating the residual")
    traces = _localise(rep, an, domain, log, compare)
    sim = _simulation(rep, an, log, compare, seed, jobs, progress, simulate, calibrate_rider)
    rep["simulation"] = None if sim is None else sim.as_json()
    rep.setdefault("simulation_why", None)
    from euc_sim.rides.balance.verdict import ride_verdict

    rep["verdict"] = ride_verdict(rep)
    # the rider's numbers (summary, mass check, battery health), from the log as parsed here
    rep.update(rider_numbers(log, rep, spec, rider_weight))
    if compare is not None:         # the compared ride's own numbers, beside LOG's on the page
        from euc_sim.rides.summary.rider_view import compared_numbers

        rep["compared"] = compared_numbers(compare, physics[2], spec, compare_rider_weight)
    from euc_sim.rides.drive.drivetrain_report import cutout_of

    rep["cutout"] = cutout_of(physics[1], log, rep["summary"]["limits"]).as_json()
    rep["report"] = None
    return RideResult(report=rep, analysis=an, traces=traces, simulation=sim, physics=physics)


def _one_parameter_set(an, physics, log, compare, n_boot: int, seed: int, say) -> dict:
    """The balance report joined with the mass, drivetrain and law, and the one ``parameters`` list."""
    from euc_sim.rides.balance.parameters import drivetrain_view, parameter_list
    from euc_sim.rides.law.controller_report import controller_json, torque_constant

    rep = dict(an.report)
    rep.update(physics[0])
    rep["notes"] = list(rep["notes"]) + [_mass_grid_note(physics[1])]
    say("reading the wheel's balance law")
    rep["controller"] = controller_json(log, compare, torque_constant(rep.get("drivetrain")),
                                        n_boot, seed)
    rep["parameters"] = parameter_list(an.cross, rep["total_mass"], rep["drivetrain"],
                                       rep["controller"])
    rep["drivetrain"] = drivetrain_view(rep["drivetrain"], rep["parameters"])
    return rep


def _localise(rep: dict, an, domain: str, log, compare) -> list:
    """Where the inertia-only residual concentrates: ``windows``, ``localisation``, traces."""
    from euc_sim.rides.balance.residual import residual_windows

    name = log.name
    nom, aug = an.cross.nominal.estimate, an.cross.augmented.estimate
    d_fit, d_test = an.designs
    traces = [residual_windows(an.sig_fit, nom, aug, domain, name, True, design=d_fit)]
    if an.sig_test is not None:
        traces.append(residual_windows(an.sig_test, nom, aug, domain, compare.name, False, design=d_test))
    loc = traces[0].localisation
    rep["windows"] = loc["windows"]
    rep["localisation"] = {"residual": f"inertia-only balance residual of {name}, "
                                       f"{rep['error_unit']}",
                           "share": loc["share"], "correlations": loc["correlations"]}
    rep["residual_traces"] = [tr.as_json() for tr in traces]
    return traces


def _simulation(rep: dict, an, log, compare, seed: int, jobs: int, progress, simulate: bool,
                calibrate_rider: bool):
    """The simulated rider, or None (not asked, or the ride cannot be simulated: ``simulation_why``
    says which, and a note why it cannot)."""
    if not simulate:
        rep["simulation_why"] = REPLAY_NOT_ASKED
        return None
    from euc_sim.rides.sim.simulate import simulation_obstacle

    why = simulation_obstacle(an.sig_test if an.sig_test is not None else an.sig_fit)
    if why is not None:
        warnings.warn(why, stacklevel=3)
        rep["notes"] = list(rep["notes"]) + [why]
        rep["simulation_why"] = why
        return None
    return _simulate(an, log, compare, seed, jobs, progress, rep, calibrate_rider)


def _mass_grid_note(fit) -> str:
    """How the mass and drivetrain fits treated the log's gaps (the ride's one grid, their own filter)."""
    import numpy as np

    from euc_sim.rides.grids.power import MassSettings

    n = len(np.unique(fit.sig.segment))
    return (f"mass and drivetrain fits: gaps up to {MassSettings.max_gap:g} s bridged linearly on "
            f"the ride's {MassSettings.rate:g} Hz grid (the balance fit's), longer ones split the "
            f"ride ({n} piece(s))")


def _rider_steps():
    from euc_sim.rides.rider.rider_step import RIDER_STEPS

    return RIDER_STEPS


def _simulate(an, log, compare, seed: int, jobs: int, progress, rep: dict, calibrate_rider: bool = False):
    """The closed-loop rider along the tested ride, once per modelled step (:mod:`euc_sim.rides.sim.sim_steps`),
    built from the fit ride's results in ``rep``; the second half scored without compare."""
    from euc_sim.rides.sim.sim_steps import STEP_BUILDERS, StepInputs, build_steps, log_channels
    from euc_sim.rides.sim.simulate import ride_params, simulate_ride

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
        progress(f"simulating the rider along {ride_path.name}: steps {', '.join(ran)}, "
                 f"{min(jobs, len(ran))} thread(s)")
    return simulate_ride(sig, steps, ride_path, scored=scored, label=ride_path.name, seed=seed,
                         workers=jobs, channels=log_channels(rep, balance), progress=progress)


def write_report(res: RideResult, out: Path) -> None:
    """Figures, tables, ``index.html`` and ``index.md`` into ``out``; ``res.report`` gets their file names.

    Everything is first written into a hidden folder inside ``out`` and moved into
    place (``index.md`` last) only once all of it exists: a failure or an
    interruption half-way leaves ``out`` as it was.
    """
    import shutil
    import tempfile

    out.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".ride-report-", dir=out))
    try:
        _write_report_files(res.report, res.analysis, res.traces, res.simulation, res.physics, stage)
        names = sorted((p.name for p in stage.iterdir()), key=lambda n: n in ("index.md", "index.html"))
        for name in names:
            os.replace(stage / name, out / name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _write_report_files(rep: dict, an, traces, sim, physics, out: Path) -> None:
    from euc_sim.io import atomic_write
    from euc_sim.rides.render.fit_figures import write_balance
    from euc_sim.rides.render.page import write_page

    rep["table"] = write_balance(an, out).name
    figures = _drivetrain_figures(physics, out)        # PNG files
    if sim is not None:
        from euc_sim.rides.render.simulation_figure import plot_ride_simulation

        figures["simulation"] = plot_ride_simulation(sim, out / "ride_simulation.png").name
        atomic_write(out / "ride_simulation.csv",
                     lambda p: sim.table.to_csv(p, index=False, float_format="%.6g"))
        rep["simulation"]["table"] = "ride_simulation.csv"
        rep["simulation"]["figure"] = figures["simulation"]
    rep["figures"] = dict(figures)
    from euc_sim.rides.render.page_html import RideSeries, first_screen, key_figure_lines, limits_md, write_ride_html

    # the page's curves come from the log as the balance fit parsed it (the fit ride's grid)
    series = RideSeries.from_frame(an.sig_fit.raw, an.sig_fit.rate)
    rep["report_markdown"] = write_page(rep, out, figures, getattr(physics[1], "path", None),
                                        key_figure_lines(rep), first_screen(rep), limits_md(rep, series)).name
    plots = _fit_plots(an, traces, physics)
    rep["report"] = write_ride_html(rep, out, series, physics[1], {**figures, **{k: k for k in plots}},
                                    plots).name


def _fit_plots(an, traces, physics) -> dict:
    """The fits' figures the page draws (Plotly), by key (the markdown's figure key, the element id)."""
    from euc_sim.rides.render import fit_figures as F

    plots = {"cross_ride": (F.balance_figure(an.cross, an.sig_fit, an.sig_test), F.BALANCE_HEIGHT),
             "residuals": (F.residuals_figure(traces), F.residuals_height(len(traces)))}
    _, fit, test = physics
    if fit.drivetrain.pwm_coef is not None:
        target = test if test is not None and "pwm" in test.sig.extra else fit
        plots["pwm"] = (F.pwm_figure(target, fit.drivetrain.pwm_coef, f"PWM of {Path(target.path).name}, "
                                     f"model fitted on {Path(fit.path).name}"), F.PWM_HEIGHT)
    return plots




def _drivetrain_figures(physics, out: Path) -> dict:
    """The envelope and grade figures of the ride page (PNG), by key -> file name."""
    from euc_sim.rides.render.drivetrain_page import plot_envelope, plot_grade

    rep, fit, _ = physics
    figs = {}
    if fit.grade is not None:
        figs["grade"] = plot_grade(fit.grade, out / "ride_grade.png",
                                   title=f"{Path(fit.path).name}: the altitude the battery-power "
                                         f"balance implies, against GPS altitude").name
    if "speed" in rep["envelope"]:
        figs["envelope"] = plot_envelope(rep["envelope"], out / "ride_envelope.png").name
    return figs


