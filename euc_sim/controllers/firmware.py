"""The wheel's measured balance law as the simulator's motor controller.

The ride JSON's ``controller`` entry (the PD law
M_d = K_p (γ − γ_ref) + K_d γ̇ of :mod:`euc_sim.rides.law.controller_law`, in N·m) is read
as :class:`LawTerm` objects by :func:`law_terms` (the ride's analysis hands over the same from its
fit); :func:`firmware_motor` turns them into a
:class:`~euc_sim.controllers.motor.MotorPD`: K_p, K_d, the torque limit and the tilt-back
where identified; what MotorPD cannot carry is listed in the notes.  A K_d the log does
not resolve is replaced by :func:`~euc_sim.controllers.damping.damping_floor` (pitch-mode
damping ratio :data:`~euc_sim.controllers.damping.ZETA_UNRESOLVED`) if larger; a fitted
torque limit below the largest |torque| the log measured is raised to it (the fit's limit
is not a bound; docs/controller.md).
"""

from __future__ import annotations

import math
from typing import Mapping, NamedTuple

from euc_sim.controllers.damping import ZETA_UNRESOLVED, damping_floor
from euc_sim.controllers.motor import MotorError, MotorPD
from euc_sim.errors import InputError
from euc_sim.model.parameters import Params, TABLE3

__all__ = ["FirmwareError", "LawTerm", "law_terms", "firmware_settings", "kd_resolved", "firmware_motor",
           "voltage_limit_settings", "voltage_limits", "CARRIED"]

#: Terms of the ``controller`` entry that MotorPD carries -> its setting.
CARRIED = {"K_p": "Kp", "K_d": "Kd", "torque_limit": "torque_limit",
           "tiltback_speed": "tiltback_speed", "tiltback_gain": "tiltback_gain"}


class FirmwareError(InputError):
    """A ride JSON ``controller`` entry that cannot drive the simulator; the message says why."""


class LawTerm(NamedTuple):
    """One term of a measured law: its estimate, 95 % interval (or None) and unit; the torque
    limit's also the largest |torque| the log measured."""

    estimate: float | None
    ci95: tuple | None
    unit: str | None
    largest_measured: float | None = None


def law_terms(ctrl) -> dict[str, LawTerm]:
    """The terms by name of a ride JSON's ``controller`` object (``law``, ``terms`` [{name, estimate,
    ci95, unit}]); :class:`FirmwareError` for one that is not an object or shows no law (its ``why`` quoted)."""
    if not isinstance(ctrl, dict):
        raise FirmwareError(f"controller: expected an object, got {type(ctrl).__name__}")
    if ctrl.get("law") is None:
        raise FirmwareError(f"controller: the ride shows no law ({ctrl.get('why', 'no why given')})")
    return {t.get("name"): LawTerm(t.get("estimate"), t.get("ci95"), t.get("unit"), t.get("largest_measured"))
            for t in ctrl.get("terms", []) if isinstance(t, dict)}


def firmware_settings(terms: Mapping[str, LawTerm], p: Params | None = None) -> tuple[dict, list[str]]:
    """MotorPD settings from a measured law's terms by name (:func:`law_terms`), and notes.

    ``p``: the ride's parameters for the damping of an unresolved K_d (default Table 3),
    given the pitch-mode damping ratio :data:`~euc_sim.controllers.damping.ZETA_UNRESOLVED`.  Returns ``settings`` (``Kp`` N·m/rad,
    ``Kd`` N·m·s/rad, and where identified ``torque_limit`` N·m, ``tiltback_speed`` m/s,
    ``tiltback_gain`` rad per m/s) and ``notes`` (what was not carried, or changed).
    ``FirmwareError`` for a law not in N·m, or a non-finite term.
    """
    if "K_p" not in terms:
        raise FirmwareError("controller: no 'K_p' term")
    if not str(terms["K_p"].unit or "").startswith("N·m"):
        raise FirmwareError(f"controller: K_p is in {terms['K_p'].unit!r}, expected N·m/rad "
                            f"(run euc-sim ride with --wheel SPEC.csv so the torque constant is known)")
    settings, notes = {}, []
    for name, key in CARRIED.items():
        if name not in terms:
            continue
        val = terms[name].estimate
        if not (isinstance(val, (int, float)) and math.isfinite(val)):
            raise FirmwareError(f"controller: term {name!r} estimate must be a finite number, got {val!r}")
        settings[key] = float(val)
    if not kd_resolved(terms.get("K_d")):
        zeta = ZETA_UNRESOLVED
        floor = damping_floor(p or TABLE3, settings["Kp"], zeta)
        est = settings.get("Kd")
        kd = max(floor, est if est is not None else 0.0)
        said = "not measured" if est is None else \
            f"measured {est:.3g} N·m·s/rad, 95 % interval {_ci(terms['K_d'])}"
        notes.append(f"K_d {said}: not resolved by the log (the interval reaches 0 or below); the simulator uses "
                     f"K_d = {kd:.3g} N·m·s/rad, " + (f"the smallest giving the pitch mode damping ratio "
                     f"{zeta:g} at K_p = {settings['Kp']:.0f} N·m/rad" if kd == floor else
                     f"the estimate (above {floor:.3g}, which gives damping ratio {zeta:g})")
                     + ("" if p is not None else " on the paper's Table 3 parameters"))
        settings["Kd"] = kd
    if settings.get("tiltback_gain", 0.0) < 0:
        notes.append("a tilt-back gain below zero (set-point tilting forward) is not carried")
        settings.pop("tiltback_gain"), settings.pop("tiltback_speed", None)
    if "tiltback_speed" in settings and "tiltback_gain" not in settings:
        settings.pop("tiltback_speed")
    for name in terms:
        if name not in CARRIED and name != "pitch_zero":
            notes.append(f"{name} = {terms[name].estimate:.3g} {terms[name].unit or ''} "
                         f"measured but not simulated (MotorPD has no such term)")
    if "torque_limit" not in settings:
        notes.append(f"no torque limit identified: MotorPD's default {MotorPD.torque_limit:g} N·m kept")
    else:
        top = terms["torque_limit"].largest_measured
        if isinstance(top, (int, float)) and math.isfinite(top) and top > settings["torque_limit"]:
            notes.append(f"torque limit: the fitted {settings['torque_limit']:.4g} N·m is below the largest "
                         f"|torque| the same log measured, {top:.4g} N·m (the firmware gave that much); "
                         f"the simulator uses {top:.4g} N·m")
            settings["torque_limit"] = float(top)
    return settings, notes


def kd_resolved(term: LawTerm | None) -> bool:
    """Whether a law's K_d term lies above zero: its 95 % interval, else its estimate."""
    if term is None:
        return False
    ci = term.ci95
    if isinstance(ci, (list, tuple)) and len(ci) == 2 and all(isinstance(c, (int, float)) for c in ci):
        return min(ci) > 0
    return (term.estimate or 0.0) > 0


def _ci(term: LawTerm) -> str:
    ci = term.ci95
    return f"[{ci[0]:.3g}, {ci[1]:.3g}]" if isinstance(ci, (list, tuple)) and len(ci) == 2 else "not given"


def firmware_motor(terms: Mapping[str, LawTerm], p: Params | None = None, **limits) -> tuple[MotorPD, list[str]]:
    """The measured law's ``terms`` as a :class:`MotorPD` with voltage ``limits``, and notes;
    ``FirmwareError`` as :func:`firmware_settings` or out of range."""
    settings, notes = firmware_settings(terms, p)
    try:
        return MotorPD(**settings, **limits), notes
    except MotorError as exc:
        raise FirmwareError(f"controller: {exc}") from None


def voltage_limit_settings(ride: dict, R: float, voltage: float | None = None) -> dict:
    """:class:`MotorPD`'s voltage-limit settings from a ride JSON's identified drivetrain.

    ``R``: wheel radius, m; ``voltage``: battery voltage, V (default the envelope's
    full-charge voltage, else ``ocv_start``).  Returns ``voltage`` V, ``back_emf`` V·s/m,
    ``drop`` = r_F/R V/(N·m), and where identified ``dead_time``, ``flux_weakening``
    V/(m/s)², ``fw_speed`` m/s; ``FirmwareError`` naming a missing or invalid field.
    """
    dt = ride.get("drivetrain") if isinstance(ride, dict) else None
    dt = dt if isinstance(dt, dict) else {}
    est = {k: t["estimate"] for k, t in dt.items()
           if isinstance(t, dict) and isinstance(t.get("estimate"), (int, float))}
    if voltage is None:                 # a malformed envelope or ocv_start counts as absent
        env = ride.get("envelope") if isinstance(ride, dict) else None
        full = env.get("full") if isinstance(env, dict) else None
        voltage = (full.get("voltage") if isinstance(full, dict) else None) or est.get("ocv_start")
    return voltage_limits(est, R, voltage)


def voltage_limits(estimates, R: float, voltage: float | None) -> dict:
    """:func:`voltage_limit_settings` from the drivetrain's estimates by name (SI) and a battery voltage, V."""
    for k in ("back_emf_per_speed", "resistive_drop"):
        if not isinstance(estimates.get(k), (int, float)):
            raise FirmwareError(f"field 'drivetrain.{k}.estimate' missing "
                                f"(written by euc-sim ride on a log with PWM)")
    if voltage is None:
        raise FirmwareError("no battery voltage; give --battery-voltage V")
    if not (isinstance(voltage, (int, float)) and math.isfinite(voltage) and voltage > 0):
        raise FirmwareError(f"battery voltage must be a finite positive number of volts, got {voltage!r}")
    r_F = estimates["resistive_drop"]
    if not (math.isfinite(r_F) and r_F > 0):
        raise FirmwareError(f"field 'drivetrain.resistive_drop.estimate' must be positive for a "
                            f"voltage limit, got {r_F!r}")
    extra = {k: float(estimates[j]) for k, j in (("dead_time", "dead_time"),
                                                 ("flux_weakening", "flux_weakening"),
                                                 ("fw_speed", "flux_weakening_up_to"))
             if isinstance(estimates.get(j), (int, float))}
    return {"voltage": float(voltage), "back_emf": float(estimates["back_emf_per_speed"]),
            "drop": float(r_F) / R, **extra}
