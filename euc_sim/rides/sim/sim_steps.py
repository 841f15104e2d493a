"""The simulation of a ride as an ordered list of modelled steps (the ride JSON's ``simulation.steps``).

The held-out log's speed profile is ridden once per step, each adding one modelled piece
to the one before, so the held-out error after each step shows what that piece bought:
``nominal`` (the paper's PD, the default LQR rider, no effects, no loss),
``measured_law`` (the wheel's balance law measured on the fit ride, the rider redesigned
for it) and ``drivetrain`` (the voltage-limited motor, the accepted effects as physics,
the augmented fit's losses in the battery power).  A step is data (:class:`SimStep`);
:data:`STEP_BUILDERS` makes each from the last one that ran and :class:`StepInputs`; a new
piece is one more builder.  :class:`LogChannels` maps the simulated state onto the log's
phase current, pitch and PWM.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Sequence

import numpy as np

from euc_sim.controllers.damping import ZETA_UNRESOLVED
from euc_sim.controllers.firmware import FirmwareError, firmware_motor, kd_resolved, voltage_limits
from euc_sim.controllers.motor import MotorPD
from euc_sim.model.parameters import Params
from euc_sim.rides.drive.pwm import BASE, EXTRA, pwm_columns
from euc_sim.rides.law.controller_report import firmware_terms, torque_constant
from euc_sim.simulation.effects import RECORDS

__all__ = ["SimStep", "motor_from_law", "StepInputs", "LogChannels", "nominal_step", "measured_law_step",
           "drivetrain_step", "STEP_BUILDERS", "SIM_EFFECTS", "effects_to_inject", "power_terms", "electrical_power", "build_steps", "TARGET_RATIO", "CHANNELS",
           "VOLTAGE_EXTRAS", "log_channels", "simulated_pwm"]

#: Target: a step's held-out battery-power error within this many times the balance fit's
#: held-out error (docs/ride_simulation.md).
TARGET_RATIO = 1.2

#: Channels a step is scored on: column stem -> (JSON key, unit, what).
CHANNELS = {"P": ("P_W", "W", "battery power"), "I": ("I_phase_A", "A", "phase current"),
            "pitch": ("pitch_rad", "rad", "body pitch"), "pwm": ("pwm_pct", "%", "PWM duty"),
            "M": ("M_Nm", "N·m", "motor torque"), "v": ("v_mps", "m/s", "wheel speed")}


#: The voltage limit's settings a drivetrain fit may add (:meth:`MotorPD.voltage_torque`); a step's
#: JSON law carries each that differs from its default.
VOLTAGE_EXTRAS = ("dead_time", "flux_weakening", "fw_speed")


def motor_from_law(law: Mapping[str, float]) -> MotorPD:
    """The motor a step's JSON ``motor`` describes (the inverse of
    :func:`euc_sim.report.ride.contract.sim_step_json`'s law)."""
    extra = ("tiltback_speed", "tiltback_gain", "voltage", "back_emf", "drop") + VOLTAGE_EXTRAS
    return MotorPD(Kp=law["K_p"], Kd=law["K_d"], torque_limit=law["torque_limit"],
                   **{k: law[k] for k in extra if k in law})


@dataclass(frozen=True)
class SimStep:
    """One modelled step of the simulated ride.

    Attributes
    ----------
    name, what : str
        ``nominal``, ``measured_law``, ...; what the step adds, one line.
    motor : MotorPD
        The wheel's balance law.
    rider : controllers.rider.Rider or None
        None: the LQR rider designed for ``motor``.
    effects : mapping
        CONTRACT effect values injected as physics.
    power : mapping
        Battery-power model: ``copper_loss`` (W/N²), ``drivetrain_idle_loss`` (W).
    notes : tuple of str
        What the step could not carry, and why.
    why : str or None
        Not None: the step is skipped (listed, not run).
    plan_window : float or None
        The rider's plan is the logged speed smoothed over this many s; None: the profile.
    rider_fit : mapping
        The fitted rider's values (``delay`` s, ``bandwidth``, ``noise_std`` N·m), where fitted.
    physics : tuple of str
        The ride's accepted parameters this step simulates.
    """

    name: str
    what: str
    motor: MotorPD = field(default_factory=MotorPD)
    rider: object = None
    effects: Mapping[str, float] = field(default_factory=dict)
    power: Mapping[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    why: str | None = None
    plan_window: float | None = None
    rider_fit: Mapping[str, float] = field(default_factory=dict)
    physics: tuple[str, ...] = ()


@dataclass(frozen=True)
class StepInputs:
    """What the steps are built from: the fit ride's results.

    Attributes
    ----------
    params : Params
    nominal, augmented : mapping
        The inertia-only and augmented balance fits' estimates.
    accepted : sequence of str
        Accepted balance effects.
    parameters : sequence of Parameter
        The ride's one parameter set.
    law : ControllerFit or None
    drivetrain : mapping of str -> Term
    voltage : float or None
        The battery's full-charge voltage, V.
    fit_log : path or None
        The fit ride's log (for steps fitted on it).
    n_boot, seed : int
        Bootstrap replicates and seed of the steps fitted on it.
    """

    params: Params
    nominal: Mapping[str, float]
    augmented: Mapping[str, float]
    accepted: Sequence[str]
    parameters: Sequence = ()
    law: object = None
    drivetrain: Mapping = field(default_factory=dict)
    voltage: float | None = None
    fit_log: object = None
    n_boot: int = 200
    seed: int = 0

    def physics(self, *names: str) -> tuple[str, ...]:
        """Those of ``names`` that are accepted entries of the ride's ``parameters``, in order."""
        ok = {p.name for p in self.parameters if p.accepted}
        return tuple(n for n in names if n in ok)


def power_terms() -> tuple[str, ...]:
    """The balance fit's battery-power terms a step's power model carries (the catalog's records
    whose balance term has an ``electrical`` power)."""
    return tuple(e.name for e in RECORDS.having("balance") if e.balance.electrical is not None)


def _power(est: Mapping[str, float]) -> dict[str, float]:
    """A step's power model: each electrical term fitted, a constant drain always (0 where not fitted)."""
    return {k: float(est.get(k, 0.0)) for k in power_terms() if k in est or RECORDS.get(k).balance.role == "constant"}


def electrical_power(power: Mapping[str, float], F: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Battery power of a step's electrical terms, W, from the motor's force F (N) and speed v (m/s)."""
    return sum((RECORDS.get(k).balance.electrical(value, F, v) for k, value in power.items()),
               np.zeros(np.shape(F)))


def nominal_step(prev: SimStep | None, inp: StepInputs) -> SimStep:
    """The paper's PD, the default rider, no effects, no loss (the inertia-only balance)."""
    return SimStep("nominal", "paper's PD motor law (600 / 40 N·m/rad), default rider, no effects",
                   MotorPD(), None, {}, _power(inp.nominal), physics=inp.physics("total_mass"))


def measured_law_step(prev: SimStep, inp: StepInputs) -> SimStep:
    """The firmware law measured on the fit ride replaces the paper's PD (the rider redesigned for it)."""
    name, what = "measured_law", "the wheel's balance law measured on the fit ride"
    if inp.law is None or inp.law.law is None:
        why = None if inp.law is None else inp.law.why
        return replace(prev, name=name, what=what, notes=(),
                       why=f"the fit ride shows no balance law ({why or 'no controller entry'})")
    terms = firmware_terms(inp.law)        # the firmware reads the law as `euc-sim sim --firmware` does
    try:
        motor, notes = firmware_motor(terms, inp.params)
    except FirmwareError as exc:
        return replace(prev, name=name, what=what, notes=(), why=str(exc))
    law_terms = [f"controller.{k}" for k in inp.law.law.terms]
    return replace(prev, physics=prev.physics + inp.physics(*law_terms),
                   name=name, what=f"{what}: K_p = {motor.Kp:.0f} N·m/rad, K_d = "
                                         f"{motor.Kd:.0f} N·m·s/rad" + ("" if kd_resolved(terms.get("K_d")) else
                                         " (K_d not resolved by the log: pitch mode damped to ζ ≥ "
                                         f"{ZETA_UNRESOLVED:g})"), motor=motor, rider=None,
                   notes=tuple(notes), why=None)


def drivetrain_step(prev: SimStep, inp: StepInputs) -> SimStep:
    """The voltage-limited motor, the accepted effects as physics, the augmented fit's power model."""
    eff, notes = effects_to_inject(inp.augmented, inp.accepted)
    motor = prev.motor
    try:
        motor = replace(prev.motor, **voltage_limits(_estimates(inp.drivetrain), inp.params.R, inp.voltage))
        limit = f"voltage-limited motor ({motor.voltage:.0f} V)"
    except (FirmwareError, ValueError) as exc:
        limit = "no voltage limit"
        notes.append(f"no voltage limit: {exc}")
    named = ", ".join(eff) or "no effect"
    power = _power(inp.augmented)
    extra = inp.physics(*eff, *power, "back_emf_per_speed", "resistive_drop", "dead_time",
                        "flux_weakening", "internal_resistance")
    return replace(prev, name="drivetrain", physics=prev.physics + tuple(
                       n for n in extra if n not in prev.physics), what=f"{limit}, accepted effects as physics ({named}), "
                                                 f"the augmented fit's losses",
                   motor=motor, effects=eff, power=power,
                   notes=tuple(notes), why=None)


#: The steps in order; each builder gets the last step that ran and the inputs.
STEP_BUILDERS: tuple[Callable[[SimStep | None, StepInputs], SimStep], ...] = (
    nominal_step, measured_law_step, drivetrain_step)


def build_steps(inp: StepInputs, builders: Sequence[Callable] = STEP_BUILDERS) -> list[SimStep]:
    """The ordered steps: ``builder(last_step_that_ran, inp)`` each (the first gets None); a
    skipped step is listed and the next builds on the last one run.
    """
    steps, last = [], None
    for make in builders:
        step = make(last, inp)
        steps.append(step)
        if step.why is None:
            last = step
    return steps


#: Fitted balance parameters that the simulator can inject as physics (records with a balance
#: term and a generalised force; their estimate converted by the term's ``to_contract``).
SIM_EFFECTS = tuple(e.name for e in RECORDS.having("balance") if e.force is not None)


def effects_to_inject(estimates: Mapping[str, float], accepted: Sequence[str]) -> tuple[dict, list]:
    """The accepted balance effects as ``simulate(effects=...)`` values, in the catalog's unit.

    Returns the effects with a generalised force (C_rr, k kg/m, slope α rad from sin α) and
    notes on the accepted ones that are not simulator physics (electrical terms go to the
    battery power).
    """
    eff, notes = {}, []
    for name in accepted:
        val = float(estimates[name])
        e = RECORDS.get(name)
        term = e.balance
        if e.force is not None and e.kind is not None:
            eff[name] = val if term is None or term.to_contract is None else term.to_contract(val)
        elif term is not None and term.electrical is not None:
            notes.append(f"{name} = {val:.3g} is electrical: added to the predicted battery "
                         f"power, not to the mechanics")
        else:
            notes.append(f"{name} is not a constant force the simulator can inject: left out "
                         f"of the augmented simulation")
    return eff, notes


# --- the log's channels -------------------------------------------------------------------
@dataclass(frozen=True)
class LogChannels:
    """How the simulated state maps onto a log's channels.

    Attributes
    ----------
    k_t : float or None
        Torque constant, N·m/A: phase current M_d/k_t.
    pwm : dict or None
        Duty model coefficients (:func:`~euc_sim.rides.drive.pwm.pwm_columns`).
    pitch_sign, pitch_zero : float or None
        ``tilt = s·γ + tilt₀`` (rad) from the measured law; None: unknown.
    balance_heldout : float or None
        The balance fit's held-out battery-power error, W.
    """

    k_t: float | None = None
    pwm: dict | None = None
    pitch_sign: float | None = None
    pitch_zero: float | None = None
    balance_heldout: float | None = None


def _estimates(terms: Mapping) -> dict[str, float]:
    """The finite estimates of the drivetrain's terms, by name."""
    return {k: float(t.estimate) for k, t in (terms or {}).items()
            if isinstance(t.estimate, (int, float)) and math.isfinite(t.estimate)}


def log_channels(drivetrain: Mapping | None = None, law=None, balance_heldout: float | None = None) -> LogChannels:
    """:class:`LogChannels` from the fit ride's drivetrain terms, balance law and held-out error (W)."""
    est = _estimates(drivetrain)
    pwm = None
    if "back_emf_per_speed" in est and "resistive_drop" in est:
        pwm = {"K_v": est["back_emf_per_speed"], "r_F": est["resistive_drop"]}
        for key, name in (("dead_time", "dead_time"), ("flux_weakening", "flux_weakening"),
                          ("v_fw", "flux_weakening_up_to")):
            if name in est:
                pwm[key] = est[name]
    sign = zero = None
    fit = None if law is None else law.law
    if fit is not None and fit.sign in (1, -1):
        sign = float(fit.sign)
        zero = float(fit.terms["pitch_zero"][0]) if "pitch_zero" in fit.terms else 0.0
    return LogChannels(k_t=torque_constant(drivetrain), pwm=pwm, pitch_sign=sign, pitch_zero=zero,
                       balance_heldout=balance_heldout)


def simulated_pwm(coef: Mapping[str, float], v: np.ndarray, F: np.ndarray,
                  V: np.ndarray) -> np.ndarray:
    """Duty, %: 100·(K_v·v + r_F·F + c_dt·V·sign F − c_fw·v·min(v, v_fw))/V.

    ``coef`` of :func:`~euc_sim.rides.drive.pwm.pwm_columns`, ``v`` m/s, ``F`` = M_d/R N,
    ``V`` battery voltage V.
    """
    names = [n for n in BASE + tuple(EXTRA) if n in coef]
    V = np.asarray(V, float)
    X = pwm_columns(np.asarray(v, float), np.asarray(F, float), V, names, coef.get("v_fw", np.inf))
    with np.errstate(invalid="ignore", divide="ignore"):
        return X @ np.array([coef[n] for n in names]) / V * 100.0
