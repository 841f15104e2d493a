"""One ride's mass, drivetrain, PWM and cut-out envelope, as the ride JSON carries them.

:func:`drivetrain_report` runs :mod:`euc_sim.rides.drive.mass` and
:mod:`euc_sim.rides.drive.drivetrain` on a log (and, with ``compare``, predicts the
other ride's battery power and PWM from this one's fit) and returns the
CONTRACT's ``total_mass``, ``drivetrain`` and ``pwm`` objects plus the
``envelope`` (drawn and worded by :mod:`euc_sim.rides.render.drivetrain_page`).  The rider's
stated weight is never read.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from euc_sim.rides.drive.drivetrain import Drivetrain, envelope, fit_drivetrain, predict_pwm
from euc_sim.rides.drive.grade import GradeProfile, grade_profile
from euc_sim.rides.drive.mass import MassFit, fit_mass, predict_power
from euc_sim.rides.drive.pwm import no_force_speed
from euc_sim.rides.drive.rotating import without_rotating_inertia
from euc_sim.rides.grids.power import MassSettings, PowerSignals, power_signals
from euc_sim.rides.source.ride import Ride
from euc_sim.rides.source.sanity import input_warnings, mass_suspicion
from euc_sim.rides.source.spec import WheelSpec
from euc_sim.rides.source.systematic import mass_difference

__all__ = ["RideDrivetrain", "analyse", "drivetrain_report", "ride_drivetrain", "cutout_of",
           "COMPUTED_PWM_RMS", "computed_pwm_note"]

#: A logged duty that its model explains better than this, percentage points, is
#: taken to be computed by the app from speed and voltage, not measured.
COMPUTED_PWM_RMS = 0.3


@dataclass(frozen=True)
class RideDrivetrain:
    """Everything identified on one ride (see :func:`analyse`)."""

    path: str
    sig: PowerSignals
    mass: MassFit
    drivetrain: Drivetrain
    spec: WheelSpec
    grade: GradeProfile | None = None


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
    return RideDrivetrain(log.path, sig, without_rotating_inertia(m_eq, spec.wheel_mass), dt, spec, grade)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else float("nan")


def computed_pwm_note(r: RideDrivetrain) -> str | None:
    """Why the logged duty of ``r`` is taken as computed by the app, or None if measured."""
    if r.drivetrain.pwm_coef is None:
        return None
    pred, obs = predict_pwm(r.sig, r.drivetrain.pwm_coef)
    rms = _rms(pred - obs)
    if rms < COMPUTED_PWM_RMS:
        return (f"the logged duty follows speed and voltage to {rms:.2f} percentage points: "
                f"the app computes it, it is not measured; the resistive drop is not identified")
    return None


def _total_mass(r: RideDrivetrain) -> dict:
    m = r.mass
    why = mass_suspicion(m.estimate)
    if why is not None:                 # never a confident absurd mass
        m = dataclasses.replace(m, estimate=None, ci95=None, stat_ci95=None, why=why, by_window={},
                                equivalent={})
    out = {"estimate": m.estimate, "ci95": list(m.ci95) if m.ci95 else None,
           "unit": "kg", "lag_s": m.lag, "speed_scale": m.scale.estimate, "speed_scale_source": m.scale.source,
           "signed_current": m.signed, "terms": m.terms, "balance": m.history,
           "n_samples": m.n_samples,
           "by_window": [{"window_s": w, "estimate": x} for w, x in m.by_window.items()],
           "equivalent_mass": m.equivalent or None,
           "systematic": dict(m.systematic) if m.estimate is not None else None,
           "statistical_ci95": list(m.stat_ci95) if m.stat_ci95 else None,
           "copper_column": m.copper_column}
    if m.estimate is None:
        out["why"] = m.why
    if r.spec.wheel_mass is not None and m.estimate is not None:
        out["rider_mass"] = {"estimate": m.estimate - r.spec.wheel_mass,
                             "ci95": [x - r.spec.wheel_mass for x in m.ci95] if m.ci95 else None,
                             "note": "total minus the spec's net weight (rider with gear)"}
    else:
        out["rider_mass"] = None
        out["rider_mass_why"] = ("no wheel weight (give --wheel SPEC.csv or --wheel-mass)"
                                 if m.estimate is not None else m.why)
    return out


def _envelope(r: RideDrivetrain, computed_note: str | None) -> dict:
    """The cut-out envelope, or why there is none (``computed_note``: :func:`computed_pwm_note`)."""
    dt = r.drivetrain
    if dt.pwm_coef is None or not dt.mass:
        return {"why": "needs the PWM model and the mass: "
                       + (dt.unidentified.get("pwm") or r.mass.why or "unavailable")}
    if computed_note:
        return {"why": computed_note}
    V = r.spec.battery_voltage or (dt.battery_coef["E0"] if dt.battery_coef else None)
    src = "spec" if r.spec.battery_voltage else "open-circuit voltage fitted at the ride's start"
    v_zero = no_force_speed(dt.pwm_coef, V)
    env = envelope(dt, V, v_max=1.05 * v_zero if v_zero else 2.0 * float(np.nanmax(r.sig.v)))
    env["voltage_source"] = src
    env["ride_top_speed"] = float(np.nanmax(r.sig.v))
    return env


def drivetrain_report(log: Ride, spec: WheelSpec = WheelSpec(), compare=None,
                      settings: MassSettings = MassSettings(), fitted: RideDrivetrain | None = None
                      ) -> tuple[dict, RideDrivetrain, RideDrivetrain | None]:
    """The ride JSON's ``total_mass``, ``drivetrain``, ``pwm``, ``envelope`` and ``wheel``.

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
    report : dict
    fit, test : RideDrivetrain
        The analyses (``test`` None without ``compare``).
    """
    r = fitted or analyse(log, spec, settings)
    dtj = r.drivetrain.as_json()
    note = computed_pwm_note(r)
    if note:
        dtj["resistive_drop"] = {"estimate": None, "ci95": None, "unit": "V/N", "why": note}
        dtj.pop("winding_resistance", None)
    rep = {"total_mass": _total_mass(r), "drivetrain": dtj, "envelope": _envelope(r, note),
           "input_warnings": input_warnings(log, r.spec, r.mass.scale),
           "wheel": r.spec.as_json(), "unidentified": dict(r.drivetrain.unidentified),
           "grade": (r.grade.as_json() if r.grade is not None else
                     {"why": "no GPS altitude, or no mass identified: no implied grade"})}
    test = None
    if compare is not None:
        test = analyse(compare, spec, settings)
        rep["mass_difference"] = mass_difference(r.mass, test.mass)
        pred, obs = predict_power(test.sig, r.mass)
        rep["power_heldout"] = {"rmse": _rms(pred - obs), "rms_power": _rms(obs), "unit": "W"}
        if r.drivetrain.pwm_coef is not None and "pwm" in test.sig.extra:
            pp, po = predict_pwm(test.sig, r.drivetrain.pwm_coef)
            rep["pwm"] = {"heldout_rmse": _rms(pp - po), "unit": "%"}
            if note:
                rep["pwm"]["note"] = note
        else:
            rep["pwm"] = {"heldout_rmse": None, "unit": "%",
                          "why": "no PWM or safety-margin column in "
                                 + (compare.name if r.drivetrain.pwm_coef else log.name)}
    return rep, r, test


def cutout_of(r: RideDrivetrain, log, limits: dict):
    """The ride's :class:`euc_sim.rides.drive.cutout.Cutout` (the JSON's ``cutout``).

    Parameters
    ----------
    r : RideDrivetrain
    log : Ride
        The same ride parsed: its battery reading (%) gives the charge.
    limits : dict
        The summary's ``limits``.
    """
    from euc_sim.rides.drive.cutout import Limits, ride_cutout

    d = log.data
    charge = None
    if "battery" in d:
        ok = np.isfinite(d["battery"].to_numpy(float))
        if ok.sum() > 1:
            charge = np.interp(r.sig.t, d["t"].to_numpy(float)[ok], d["battery"].to_numpy(float)[ok])
    why = ("the log's PWM is the app's computation from speed and voltage, not a measurement: it does "
           "not show the load, so neither does a model of it") if computed_pwm_note(r) else None
    return ride_cutout(r.sig, r.drivetrain, r.mass, charge, Limits(**limits), r.spec.battery_voltage, why)


def ride_drivetrain(log, compare=None, spec=None, n_boot: int = 200, seed: int = 0):
    """Mass, drivetrain, PWM and envelope of a ride log, as ``euc-sim ride`` reports them.

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
    tuple
        :func:`drivetrain_report`'s (report, fit, test).
    """
    from euc_sim.rides.grids.power import MassSettings
    from euc_sim.rides.source.spec import WheelSpec

    return drivetrain_report(log, spec or WheelSpec(), compare, MassSettings(n_boot=n_boot, seed=seed))
