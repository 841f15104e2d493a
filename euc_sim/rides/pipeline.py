"""The ride pipeline: a validated :class:`~euc_sim.rides.request.RideRequest` in, a typed
:class:`~euc_sim.rides.result.RideResult` out, no file written.

The steps, in order: mass and drivetrain, the bounded balance fit with its held-out selection,
the balance law, the one parameter set, the residual's localisation, the simulated rider, the
verdict.  The JSON (:func:`euc_sim.report.ride.contract.ride_json`) and the report folder
(:func:`euc_sim.report.ride.report_files.write_report`) render the result.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from euc_sim.rides.balance.analysis import ride_analysis
from euc_sim.rides.balance.parameters import drivetrain_view, effect_estimates, parameter_list
from euc_sim.rides.balance.residual import residual_windows
from euc_sim.rides.balance.verdict import verdict_of
from euc_sim.rides.compare.differences_report import pair_differences
from euc_sim.rides.drive.drivetrain_report import (cutout_of, reported_mass, reported_terms,
                                                   ride_drivetrain)
from euc_sim.rides.grids.power import MassSettings
from euc_sim.rides.grids.signals import RideAssumptions, with_found_values
from euc_sim.rides.law.controller_report import controller_fit, torque_constant
from euc_sim.rides.request import RideRequest
from euc_sim.rides.result import ComparedRide, RideResult
from euc_sim.rides.rider.rider_step import RIDER_STEPS
from euc_sim.rides.sim.sim_steps import STEP_BUILDERS, StepInputs, build_steps, log_channels
from euc_sim.rides.sim.simulate import ride_params, simulate_ride, simulation_obstacle
from euc_sim.rides.summary.rider_view import rider_numbers

__all__ = ["BalanceOnMass", "balance_on_mass", "ride_pipeline"]

#: ``simulation_why`` (and the page) when the replay was not asked for.
REPLAY_NOT_ASKED = ("not run: a step you ask for (the MuJoCo rider along this ride's speed, one run per "
                    "modelled step, minutes): euc-sim ride LOG.csv --simulate (with --compare it runs "
                    "unless --no-simulate)")


@dataclass(frozen=True)
class BalanceOnMass:
    """The first two steps of a ride: the energy balance's mass, then the balance fit given it.

    Attributes
    ----------
    physics : MassDrivetrain
        :func:`~euc_sim.rides.drive.drivetrain_report.ride_drivetrain`'s result.
    assumptions : RideAssumptions
        Those handed to the balance fit (the log's total mass, the spec's radius).
    analysis : RideAnalysis
        :func:`~euc_sim.rides.balance.analysis.ride_analysis`'s result.
    """

    physics: tuple
    assumptions: object
    analysis: object


def balance_on_mass(log, compare=None, spec=None, *, assumptions=None, domain: str = "power",
                    n_boot: int = 200, seed: int = 0, n_boot_mass: int | None = None,
                    progress=None) -> BalanceOnMass:
    """The total mass from the log's energy balance, then the balance fit given it (:func:`ride_pipeline`'s first steps).

    Parameters
    ----------
    log, compare : Ride
    spec : WheelSpec, optional
    assumptions : RideAssumptions, optional
        Values given by the user; the spec's radius and the log's mass fill the rest.
    domain : {"power", "torque"}
    n_boot, seed : int
        Bootstrap replicates of the balance fit; the seed of every draw.
    n_boot_mass : int, optional
        Replicates of the mass fit (default ``n_boot``).
    progress : callable, optional
    """
    say = progress or (lambda s: None)
    say("finding the total mass and the drivetrain")
    physics = ride_drivetrain(log, compare, spec, n_boot if n_boot_mass is None else n_boot_mass, seed)
    # the spec's radius and the mass this log gives reach the balance fit (Table 3 only where
    # neither the command line, the spec nor the log gives a value)
    assumptions = with_found_values(assumptions or RideAssumptions(), spec, physics.mass.estimate,
                                    (physics.mass.equivalent or {}).get("estimate"))
    an = ride_analysis(log, compare, assumptions=assumptions, domain=domain, n_boot=n_boot,
                       seed=seed, progress=progress)
    return BalanceOnMass(physics, assumptions, an)


def ride_pipeline(req: RideRequest, *, jobs: int = 1, progress=None) -> RideResult:
    """Everything ``euc-sim ride`` computes on ``req``; ``jobs`` threads the simulation (results do not depend on it)."""
    log, compare, spec, n_boot, seed = req.log, req.compare, req.spec, req.n_boot, req.seed
    say = progress or (lambda s: None)
    # each grid is built once and kept on its ride; bad logs fail in the mass fit, before any output
    fitted = balance_on_mass(log, compare, spec, assumptions=req.assumptions, domain=req.domain,
                             n_boot=n_boot, seed=seed, progress=say)
    mass, an = fitted.physics, fitted.analysis
    say("reading the wheel's balance law")
    law = controller_fit(log, compare, torque_constant(mass.terms), n_boot, seed)
    parameters = parameter_list(an.cross, mass.mass, mass.terms, law)
    drivetrain = drivetrain_view(mass.terms, parameters)
    differences = None
    if compare is not None:     # what differs between the two rides (rides.compare.differences), each
        # ride's terms from its own energy-balance fit, so both sides are read alike
        differences = pair_differences(mass, log, compare, n_boot, seed)
    say("locating the residual")
    traces = _localise(an, log, compare)
    notes = tuple(an.notes) + (_mass_grid_note(mass.fit),)
    sim, why = _simulation(an, log, compare, n_boot, seed, jobs, progress, req.simulate, req.calibrate_rider,
                           law, parameters, drivetrain, mass)
    if sim is None and why != REPLAY_NOT_ASKED:
        notes += (why,)
    verdict = verdict_of(an.cross, parameters, mass.unidentified.get("battery_power"), an.error_unit)
    # the rider's numbers (summary, mass check, battery health), from the log as parsed here
    rider = rider_numbers(log, mass.mass, drivetrain, spec, req.rider_weight)
    compared = None
    if compare is not None:         # the compared ride's own numbers, beside LOG's on the page
        test, test_mass = mass.test, reported_mass(mass.test)
        compared = ComparedRide(Path(compare.path).name, test, test_mass, rider_numbers(
            compare, test_mass, reported_terms(test), spec, req.compare_rider_weight))
    cutout = cutout_of(mass, rider.summary.limits)
    return RideResult(balance=an, notes=notes, mass=mass, law=law, parameters=parameters,
                      effects=effect_estimates(an.cross, parameters), drivetrain=drivetrain,
                      differences=differences, traces=tuple(traces), simulation=sim, simulation_why=why,
                      verdict=verdict, rider=rider, compared=compared, cutout=cutout)


def _localise(an, log, compare) -> list:
    """Where the inertia-only residual concentrates: the residual traces of the fit (and test) ride."""
    nom, aug = an.cross.nominal.estimate, an.cross.augmented.estimate
    d_fit, d_test = an.designs
    traces = [residual_windows(d_fit, nom, aug, log.name, True)]
    if an.sig_test is not None:
        traces.append(residual_windows(d_test, nom, aug, compare.name, False))
    return traces


def _simulation(an, log, compare, n_boot: int, seed: int, jobs: int, progress, simulate: bool,
                calibrate_rider: bool, law, parameters, drivetrain, mass):
    """The simulated rider and None, or None and why there is none (a warning when the ride cannot be simulated)."""
    if not simulate:
        return None, REPLAY_NOT_ASKED
    why = simulation_obstacle(an.sig_test if an.sig_test is not None else an.sig_fit)
    if why is not None:
        warnings.warn(why, stacklevel=3)
        return None, why
    return _simulate(an, log, compare, n_boot, seed, jobs, progress, calibrate_rider, law, parameters,
                     drivetrain, mass), None


def _mass_grid_note(fit) -> str:
    """How the mass and drivetrain fits treated the log's gaps (the ride's one grid, their own filter)."""
    n = len(np.unique(fit.sig.segment))
    return (f"mass and drivetrain fits: gaps up to {MassSettings.max_gap:g} s bridged linearly on "
            f"the ride's {MassSettings.rate:g} Hz grid (the balance fit's), longer ones split the "
            f"ride ({n} piece(s))")


def _simulate(an, log, compare, n_boot: int, seed: int, jobs: int, progress, calibrate_rider: bool, law, parameters,
              drivetrain, mass):
    """The closed-loop rider along the tested ride, once per modelled step; without compare, the second half scored."""
    sig = an.sig_test if an.sig_test is not None else an.sig_fit
    ride_path = compare if compare is not None else log
    scored = None
    if an.sig_test is None:          # score the held-out second half only
        t = sig.frame["t"].to_numpy()
        scored = t >= an.cross.test_design.t.min()      # the test half's first row
    cr = an.cross
    ocv = drivetrain.get("ocv_start")
    full = mass.envelope.full
    voltage = full.voltage if full is not None else (None if ocv is None else ocv.estimate)
    steps = build_steps(StepInputs(ride_params(sig.assumptions), cr.nominal.estimate,
                                   cr.augmented.estimate, cr.accepted, parameters, law, drivetrain,
                                   voltage, log, n_boot, seed),
                        RIDER_STEPS if calibrate_rider else STEP_BUILDERS)
    ran = [s.name for s in steps if s.why is None]
    # the steps' battery-power errors are compared with the balance fit's held-out error (in W)
    balance = cr.heldout_augmented if an.error_unit == "W" else None
    if progress is not None:
        progress(f"simulating the rider along {ride_path.name}: steps {', '.join(ran)}, "
                 f"{min(jobs, len(ran))} thread(s)")
    return simulate_ride(sig, steps, ride_path, scored=scored, label=ride_path.name, seed=seed,
                         workers=jobs, channels=log_channels(drivetrain, law, balance), progress=progress)
