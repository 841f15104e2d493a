"""The typed result of :func:`euc_sim.rides.pipeline.ride_pipeline`: the analyses' own objects, no file.

CONTRACT's JSON (:func:`euc_sim.report.ride.contract.ride_json`) and the report folder
(:func:`euc_sim.report.ride.report_files.write_report`) are renderings of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from euc_sim.rides.balance.analysis import RideAnalysis
from euc_sim.rides.balance.parameters import Parameter
from euc_sim.rides.balance.verdict import Verdict
from euc_sim.rides.compare.differences import Differences
from euc_sim.rides.drive.cutout import Cutout
from euc_sim.rides.drive.mass import MassFit
from euc_sim.rides.law.controller_report import ControllerFit
from euc_sim.rides.drive.drivetrain_report import MassDrivetrain, RideDrivetrain
from euc_sim.rides.balance.residual import ResidualTrace
from euc_sim.rides.summary.rider_view import RiderNumbers
from euc_sim.rides.sim.simulate import RideSimulation

__all__ = ["RideResult", "RiderNumbers", "ComparedRide"]


@dataclass(frozen=True)
class ComparedRide:
    """The compared ride's own numbers: file name, mass and drivetrain analysis, reported mass, :class:`RiderNumbers`."""

    recording: str
    drivetrain: RideDrivetrain
    mass: MassFit
    rider: RiderNumbers


@dataclass(frozen=True)
class RideResult:
    """Everything :func:`~euc_sim.rides.pipeline.ride_pipeline` computed, in its typed objects.

    Attributes
    ----------
    balance : RideAnalysis
        The bounded balance fit with its held-out selection (``balance.cross``).
    notes : tuple of str
        The balance fit's notes, the mass fit's grid, why the ride cannot be simulated.
    mass : MassDrivetrain
        Total mass, drivetrain, PWM model and envelope.
    law : ControllerFit
        The wheel's balance law.
    parameters : tuple of Parameter
        Every fitted quantity once.
    effects : tuple of Parameter
        The effects the balance fit accepted, in the order kept, with their evidence.
    drivetrain : dict of str -> Term
        The drivetrain with the balance fit's road and loss terms.
    differences : Differences or None
        What differs between the two rides (None without ``compare``).
    traces : tuple of ResidualTrace
        The inertia-only and augmented residuals of each ride, with where they concentrate.
    simulation : RideSimulation or None
    simulation_why : str or None
        Why there is no simulation.
    verdict : Verdict
    rider : RiderNumbers
        The fit ride's.
    compared : ComparedRide or None
    cutout : Cutout
        The speed at which the wheel runs out of duty, against its charge.
    """

    balance: RideAnalysis
    notes: tuple[str, ...]
    mass: MassDrivetrain
    law: ControllerFit
    parameters: tuple[Parameter, ...]
    effects: tuple[Parameter, ...]
    drivetrain: dict
    differences: Differences | None
    traces: tuple[ResidualTrace, ...]
    simulation: RideSimulation | None
    simulation_why: str | None
    verdict: Verdict
    rider: RiderNumbers
    compared: ComparedRide | None
    cutout: Cutout
