"""What ``euc-sim ride`` computed on one log (and the ride it is compared with): a typed tree.

:func:`euc_sim.rides.pipeline.ride_pipeline` returns a :class:`RideResult`; it holds the
analyses' own objects (the balance fit, the mass and drivetrain fits, the balance law, the
simulated rider, the differences between two rides, the summary, the verdict) and writes no
file.  The JSON CONTRACT.md describes is one rendering of it
(:func:`euc_sim.rides.render.contract.ride_json`), the report folder another
(:func:`euc_sim.rides.render.report_files.write_report`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from euc_sim.rides.balance.analysis import RideAnalysis
from euc_sim.rides.balance.verdict import Verdict
from euc_sim.rides.drive.battery import BatteryHealth
from euc_sim.rides.drive.cutout import Cutout
from euc_sim.rides.report.drivetrain_report import RideDrivetrain
from euc_sim.rides.report.summary import MassCheck, RideSummary

__all__ = ["RideResult", "MassDrivetrain", "RiderNumbers", "ComparedRide"]


@dataclass(frozen=True)
class MassDrivetrain:
    """The total mass, the drivetrain, the PWM model and the envelope of the fit ride.

    Attributes
    ----------
    fit : RideDrivetrain
        The fit ride's analysis: its :class:`~euc_sim.rides.drive.mass.MassFit`,
        :class:`~euc_sim.rides.drive.drivetrain.Drivetrain`, grade profile and wheel spec.
    test : RideDrivetrain or None
        The compared ride's own analysis (None without ``compare``).
    view : dict
        :func:`~euc_sim.rides.report.drivetrain_report.drivetrain_report`'s objects of the fit
        ride (``total_mass``, ``drivetrain`` before the balance's terms replace the energy
        balance's, ``envelope``, ``input_warnings``, ``wheel``, ``unidentified``, ``grade``;
        with ``compare`` also ``mass_difference``, ``power_heldout`` and ``pwm``).
    """

    fit: RideDrivetrain
    test: RideDrivetrain | None
    view: dict


@dataclass(frozen=True)
class RiderNumbers:
    """The numbers a rider reads first, of one ride.

    Attributes
    ----------
    summary : RideSummary
        Distance, time, speed, energy, battery, limits (:mod:`euc_sim.rides.report.summary`).
    mass_check : MassCheck
        The declared rider weight against the log's total mass.
    battery : BatteryHealth
        The pack's internal resistance against what its cells give.
    clock : dict
        :func:`~euc_sim.rides.report.rider_view.ride_clock`: when the ride ran, in its zone.
    """

    summary: RideSummary
    mass_check: MassCheck
    battery: BatteryHealth
    clock: dict


@dataclass(frozen=True)
class ComparedRide:
    """The compared ride's own numbers, beside the fit ride's.

    Attributes
    ----------
    recording : str
        The compared log's file name.
    drivetrain : RideDrivetrain
        Its own mass and drivetrain analysis.
    view : dict
        Its :func:`~euc_sim.rides.report.drivetrain_report.drivetrain_report` objects.
    rider : RiderNumbers
    """

    recording: str
    drivetrain: RideDrivetrain
    view: dict
    rider: RiderNumbers


@dataclass(frozen=True)
class RideResult:
    """Everything :func:`~euc_sim.rides.pipeline.ride_pipeline` computed, in its typed objects.

    Attributes
    ----------
    balance : RideAnalysis
        The bounded balance fit with its held-out selection
        (:class:`~euc_sim.rides.balance.crossride.CrossRide` inside).
    notes : tuple of str
        The ride's notes: the balance fit's, the mass fit's grid, why the ride cannot be
        simulated.
    mass : MassDrivetrain
        Total mass, drivetrain, PWM model and envelope.
    law : dict
        The wheel's balance law (:func:`~euc_sim.rides.law.controller_report.controller_json`).
    parameters : tuple of dict
        Every fitted quantity once (:func:`~euc_sim.rides.balance.parameters.parameter_list`).
    drivetrain : dict
        The drivetrain with the balance fit's road and loss terms
        (:func:`~euc_sim.rides.balance.parameters.drivetrain_view`).
    differences : Differences or None
        What differs between the two rides (None without ``compare``).
    traces : tuple of ResidualTrace
        The inertia-only and augmented residuals of the fit ride (and the compared ride),
        with where they concentrate.
    simulation : RideSimulation or None
        The simulated rider along the tested ride.
    simulation_why : str or None
        Why there is no simulation.
    verdict : Verdict
    rider : RiderNumbers
        The fit ride's summary, mass check, battery and clock.
    compared : ComparedRide or None
    cutout : Cutout
        The speed at which the wheel runs out of duty, against its charge.
    """

    balance: RideAnalysis
    notes: tuple[str, ...]
    mass: MassDrivetrain
    law: dict
    parameters: tuple
    drivetrain: dict
    differences: Any
    traces: tuple
    simulation: Any
    simulation_why: str | None
    verdict: Verdict
    rider: RiderNumbers
    compared: ComparedRide | None
    cutout: Cutout

    @property
    def recording(self) -> str:
        """The fit log's file name."""
        return self.balance.fit_name
