"""One ride's mass, drivetrain, PWM model and cut-out envelope.

:func:`mass_drivetrain` runs :mod:`euc_sim.rides.drive.mass` and
:mod:`euc_sim.rides.drive.drivetrain` on a log (and, with ``compare``, predicts the
other ride's battery power and PWM from this one's fit) and returns a
:class:`MassDrivetrain` (the JSON's ``total_mass``, ``drivetrain``, ``pwm`` and
``envelope``: :mod:`euc_sim.report.ride.contract`; drawn and worded by
:mod:`euc_sim.report.ride.drivetrain_page`).  The rider's stated weight is never read.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from euc_sim.rides.drive.cutout import (Cutout, DutyModel, Envelope, cutout_curves, duty_model, envelope,
                                        heldout_pwm_rmse, ocv_line)
from euc_sim.rides.drive.drivetrain import Drivetrain, Term, fit_drivetrain, predict_pwm
from euc_sim.rides.drive.grade import GradeProfile, grade_profile
from euc_sim.rides.drive.mass import MassFit, fit_mass, predict_power
from euc_sim.rides.drive.rotating import without_rotating_inertia
from euc_sim.rides.grids.power import MassSettings, PowerSignals, power_signals
from euc_sim.rides.source.ride import Ride
from euc_sim.rides.source.sanity import input_warnings, mass_suspicion
from euc_sim.rides.source.spec import WheelSpec
from euc_sim.rides.source.systematic import MassDifference, mass_difference
from euc_sim.stats import rms

__all__ = ["DutyCheck", "RideDrivetrain", "MassDrivetrain", "analyse", "mass_drivetrain", "ride_drivetrain",
           "reported_mass", "reported_terms", "cutout_of"]

#: A logged duty that its model explains better than this, percentage points, is
#: taken to be computed by the app from speed and voltage, not measured.
COMPUTED_PWM_RMS = 0.3


@dataclass(frozen=True)
class DutyCheck:
    """A PWM model's duty on ride ``path`` against the logged one where both exist
    (:func:`~euc_sim.rides.drive.drivetrain.predict_pwm`): ``predicted``, ``logged`` (%) and their
    RMS difference ``rmse`` (percentage points)."""

    path: str
    predicted: np.ndarray
    logged: np.ndarray
    rmse: float


def duty_check(path: str, sig: PowerSignals, pwm_coef: dict) -> DutyCheck:
    """The duty of ``sig`` (ride ``path``) predicted by the PWM model ``pwm_coef``, checked against the log."""
    pred, obs = predict_pwm(sig, pwm_coef)
    return DutyCheck(path, pred, obs, rms(pred - obs))


@dataclass(frozen=True)
class RideDrivetrain:
    """Everything identified on one ride (see :func:`analyse`); ``pwm_note`` says why its logged
    duty is taken as the app's computation (:func:`_computed_pwm_note`), None where measured;
    ``duty`` its PWM model's check on itself (None without a model)."""

    path: str
    sig: PowerSignals
    mass: MassFit
    drivetrain: Drivetrain
    spec: WheelSpec
    grade: GradeProfile | None = None
    pwm_note: str | None = None
    duty: DutyCheck | None = None


def analyse(log: Ride, spec: WheelSpec = WheelSpec(), settings: MassSettings = MassSettings()
            ) -> RideDrivetrain:
    """Filter and fit one ride (mass, then drivetrain, then the grade it implies)."""
    sig = power_signals(log, settings)       # the ride keeps its grid: built once
    m_eq = fit_mass(log, settings, sig=sig)
    # the drivetrain balances power with m_eq (eq. 6): the rotating inertia is accelerated too
    dt = fit_drivetrain(sig, m_eq, radius=spec.radius, n_boot=max(10, settings.n_boot // 2),
                        seed=settings.seed)
    alt = log.data["gps_alt"].to_numpy(float) if "gps_alt" in log.data else None
    grade = None if alt is None else grade_profile(sig, m_eq, log.data["t"].to_numpy(float), alt)
    own = None if dt.pwm_coef is None else duty_check(log.path, sig, dt.pwm_coef)
    return RideDrivetrain(log.path, sig, without_rotating_inertia(m_eq, spec.wheel_mass), dt, spec, grade,
                          _computed_pwm_note(own), own)


def _computed_pwm_note(own: DutyCheck | None) -> str | None:
    """Why the logged duty is taken as computed by the app (its model's check on the ride, ``own``,
    within :data:`COMPUTED_PWM_RMS`), or None if measured."""
    if own is not None and own.rmse < COMPUTED_PWM_RMS:
        return (f"the logged duty follows speed and voltage to {own.rmse:.2f} percentage points: "
                f"the app computes it, it is not measured; the resistive drop is not identified")
    return None


def reported_mass(r: RideDrivetrain) -> MassFit:
    """The ride's total mass as reported: an absurd estimate withdrawn, with why (never a
    confident absurd mass)."""
    why = mass_suspicion(r.mass.estimate)
    if why is None:
        return r.mass
    return dataclasses.replace(r.mass, estimate=None, ci95=None, stat_ci95=None, why=why, by_window={},
                               equivalent={})


def reported_terms(r: RideDrivetrain) -> dict[str, Term]:
    """The drivetrain's terms as reported, by name: the identified ones, then each term the log
    cannot identify (estimate None, with why); where the logged duty is the app's computation
    (``r.pwm_note``) the resistive drop is not identified and the winding resistance left out."""
    terms = dict(r.drivetrain.terms)
    for k, why in r.drivetrain.unidentified.items():
        terms.setdefault(k, Term(None, None, None, why=why))
    if r.pwm_note:
        terms["resistive_drop"] = Term(None, None, "V/N", why=r.pwm_note)
        terms.pop("winding_resistance", None)
    return terms


def duty_model_of(r: RideDrivetrain, log) -> DutyModel | str:
    """The ride's :class:`~euc_sim.rides.drive.cutout.DutyModel` (the cut-out chart's and the envelope's),
    its charge turned into volts by the log's battery reading (``log``: the same ride parsed) or the
    spec's voltage (:func:`~euc_sim.rides.drive.cutout.ocv_line`); or why there is none."""
    dt, d, charge = r.drivetrain, log.data, None
    if dt.pwm_coef is None:
        return dt.unidentified.get("pwm") or "no PWM in the log"
    if not dt.mass or not dt.battery_coef:
        return "needs the mass and the battery found from the log"
    if "battery" in d:
        ok = np.isfinite(d["battery"].to_numpy(float))
        if ok.sum() > 1:
            charge = np.interp(r.sig.t, d["t"].to_numpy(float)[ok], d["battery"].to_numpy(float)[ok])
    line = ocv_line(r.sig.extra["voltage"], r.sig.extra.get("current"), charge, dt.battery_coef["R_int"],
                    r.spec.battery_voltage)
    if line is None:
        return ("no battery reading in the log and no battery voltage in the spec: the charge cannot be turned "
                "into volts")
    return duty_model(dt, r.mass, line)


def _envelope(r: RideDrivetrain, duty: DutyModel | str) -> Envelope:
    """The cut-out envelope of the ride's ``duty`` model (:func:`duty_model_of`), or why there is none."""
    dt = r.drivetrain
    if dt.pwm_coef is None or not dt.mass:
        return Envelope(why="needs the PWM model and the mass: "
                            + (dt.unidentified.get("pwm") or r.mass.why or "unavailable"))
    if isinstance(duty, str):
        return Envelope(why=duty)
    return envelope(duty, float(np.nanmax(r.sig.v)))


@dataclass(frozen=True)
class MassDrivetrain:
    """The total mass, the drivetrain, the PWM model and the envelope of a ride.

    Attributes
    ----------
    fit : RideDrivetrain
        The ride's analysis (:func:`analyse`).
    test : RideDrivetrain or None
        The compared ride's own analysis (None without one).
    mass : MassFit
        The total mass as reported (:func:`reported_mass`).
    terms : dict of str -> Term
        The drivetrain's terms as reported (:func:`reported_terms`).
    envelope : Envelope
        What the voltage leaves against speed at full and empty charge, or why there is none.
    input_warnings : list of str
        What the log and the spec say against each other.
    duty : DutyModel or str
        The duty model the envelope and the cut-out chart share (:func:`duty_model_of`), or why there is
        none (the computed-duty note first).
    mass_difference : MassDifference or None
        The compared ride's mass minus this one's
        (:func:`euc_sim.rides.source.systematic.mass_difference`).
    power_heldout : tuple of float or None
        The compared ride's battery power predicted from this ride's mass fit: (RMS error,
        RMS power), W.
    duty_heldout : DutyCheck or None
        The compared ride's duty predicted from this ride's PWM model.
    pwm_why : str or None
        Why there is no ``pwm_heldout`` (with a compared ride).
    """

    fit: RideDrivetrain
    test: RideDrivetrain | None
    mass: MassFit
    terms: dict
    envelope: Envelope
    input_warnings: list
    duty: DutyModel | str
    mass_difference: MassDifference | None = None
    power_heldout: tuple | None = None
    pwm_why: str | None = None
    duty_heldout: DutyCheck | None = None

    @property
    def pwm_heldout(self) -> float | None:
        """The compared ride's duty predicted from this ride's PWM model, RMS percentage points."""
        return None if self.duty_heldout is None else self.duty_heldout.rmse

    @property
    def duty_shown(self) -> DutyCheck | None:
        """The PWM model's check the page draws: on the compared ride where it was made, else on this one."""
        return self.duty_heldout or self.fit.duty

    @property
    def pwm_unchecked(self) -> str | None:
        """Why the compared ride's duty predicted from this one checks nothing (this ride's logged duty
        is the app's computation), or None: said only where that prediction was made."""
        return self.fit.pwm_note if self.test is not None and self.pwm_why is None else None

    @property
    def unidentified(self) -> dict[str, str]:
        """Term -> why this log cannot identify it."""
        return self.fit.drivetrain.unidentified


def mass_drivetrain(log: Ride, spec: WheelSpec = WheelSpec(), compare=None,
                    settings: MassSettings = MassSettings(), fitted: RideDrivetrain | None = None
                    ) -> MassDrivetrain:
    """The total mass, drivetrain, PWM model and envelope of ``log``.

    Parameters
    ----------
    log : Ride
        The ride.
    spec : WheelSpec
        Wheel radius, weight, voltage where known.
    compare : Ride, optional
        Another ride of the same wheel: its battery power and PWM are predicted
        from this ride's fit (held out).
    settings : MassSettings
    fitted : RideDrivetrain, optional
        :func:`analyse` of ``log`` already done.

    Returns
    -------
    MassDrivetrain
    """
    r = fitted or analyse(log, spec, settings)
    duty = r.pwm_note or duty_model_of(r, log)
    out = dict(fit=r, test=None, mass=reported_mass(r), terms=reported_terms(r),
               envelope=_envelope(r, duty), input_warnings=input_warnings(log, r.spec, r.mass.scale), duty=duty)
    if compare is None:
        return MassDrivetrain(**out)
    test = analyse(compare, spec, settings)
    pred, obs = predict_power(test.sig, r.mass)
    out.update(test=test, mass_difference=mass_difference(r.mass, test.mass),
               power_heldout=(rms(pred - obs), rms(obs)))
    if r.drivetrain.pwm_coef is not None and "pwm" in test.sig.extra:
        out["duty_heldout"] = duty_check(test.path, test.sig, r.drivetrain.pwm_coef)
    else:
        out["pwm_why"] = "no PWM or safety-margin column in " + (compare.name if r.drivetrain.pwm_coef else log.name)
    return MassDrivetrain(**out)


def cutout_of(md: MassDrivetrain, limits) -> Cutout:
    """The ride's :class:`euc_sim.rides.drive.cutout.Cutout` (the JSON's ``cutout``), or one saying why
    there is none: an app's computed duty has neither curves nor a held-out error (the model fits the
    app's formula, whatever the load: it checks nothing).

    Parameters
    ----------
    md : MassDrivetrain
        The ride's fit (:func:`mass_drivetrain`): its duty model and computed-duty note.
    limits : Limits
        The wheel's limits (the summary's).
    """
    if md.fit.pwm_note:
        return Cutout(why="the log's PWM is the app's computation from speed and voltage, not a measurement: "
                          "it does not show the load, so neither does a model of it")
    if md.fit.drivetrain.pwm_coef is None:
        return Cutout(why=md.duty)
    heldout = heldout_pwm_rmse(md.fit.sig)
    if isinstance(md.duty, str):
        return Cutout(heldout_pwm_rmse_pct=heldout, why=md.duty)
    return cutout_curves(md.duty, limits, heldout)


def ride_drivetrain(log, compare=None, spec=None, n_boot: int = 200, seed: int = 0) -> MassDrivetrain:
    """Mass, drivetrain, PWM and envelope of a ride log, as ``euc-sim ride`` finds them.

    Parameters
    ----------
    log, compare : Ride
        The fit ride and, optionally, the held-out ride.
    spec : WheelSpec, optional
        The wheel's specification (default: none known).
    n_boot : int
        Bootstrap replicates of the mass fit.
    seed : int
        Seed of the bootstrap draws.

    Returns
    -------
    MassDrivetrain
    """
    return mass_drivetrain(log, spec or WheelSpec(), compare, MassSettings(n_boot=n_boot, seed=seed))
