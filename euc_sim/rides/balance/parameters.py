"""The ride's one parameter set: every fitted physical quantity once, with its verdict.

The ride JSON's ``parameters`` (CONTRACT, "Added in session 4") lists each
quantity once: the balance fit's resistances and losses
(:mod:`euc_sim.rides.balance.crossride`, bounded fits, effects kept by blocked held-out
validation), the total mass (:mod:`euc_sim.rides.drive.mass`), the battery and motor
terms (:mod:`euc_sim.rides.drive.drivetrain`) and the balance law's terms
(:mod:`euc_sim.rides.law.controller_report`).  ``drivetrain``, ``total_mass``,
``controller`` and ``effects`` are views: :func:`drivetrain_view` rewrites the
drivetrain object so that its road and loss terms repeat the numbers of the
balance fit (the energy balance's own speed and loss coefficients are nuisance
terms of the mass and are not shown as C_rr, C_dA or P₀).
"""

from __future__ import annotations

import math
from typing import Mapping

from euc_sim.rides.balance.crossride import CrossRide
from euc_sim.rides.balance.fit import plausibility
from euc_sim.rides.grids.power import RHO_AIR

__all__ = ["parameter_list", "drivetrain_view", "DRIVETRAIN_PLAUSIBLE",
           "MASS_NUISANCE"]

#: Plausible ranges of the battery and motor terms (the drivetrain view's names), SI.
DRIVETRAIN_PLAUSIBLE: dict[str, tuple[float, float]] = {
    "internal_resistance": (0.0, 2.0),
    "ocv_start": (10.0, 200.0),
    "ocv_per_Ah": (0.0, 20.0),
    "speed_scale": (0.8, 1.2),
    "back_emf_per_speed": (0.0, 50.0),
    "back_emf_constant": (0.0, 20.0),
    "resistive_drop": (0.0, 1.0),
    "winding_resistance": (0.0, 2.0),
    "phase_resistance_pwm": (0.0, 2.0),
}

#: Drivetrain entries that are the energy balance's nuisance terms (fitted for the mass):
#: C_rr, C_dA and the no-load power are the balance fit's, the rest is not shown.
MASS_NUISANCE = ("C_rr", "C_dA", "no_load_power", "copper_loss_per_force2",
                 "copper_loss_per_accel2", "grade_mass")


def _balance_entries(cr: CrossRide) -> list[dict]:
    """The balance fit's parameters: the augmented fit's where kept, the full fit's otherwise."""
    aug, full = plausibility(cr.augmented), plausibility(cr.full)
    out = []
    for name in list(cr.augmented.names) + [n for n in cr.full.names if n not in cr.augmented.names]:
        e = aug.get(name) or full[name]
        kept = name in cr.accepted
        if kept:
            accepted = e["plausible"]
            why = (f"accepted on the edge of its plausible range: the ride asks for more than "
                   f"plausible {e['symbol']} gives" if e["on_bound"] else None)
        elif name in cr.selected:
            accepted = False
            why = ("it would lower the held-out error only in a model with a term outside its "
                   "plausible range (its own or another's, or a P₀ above the log's standstill power): "
                   "left out of the balance, not named, not simulated")
        else:
            accepted = False
            why = (f"not kept: it lowers the blocked held-out error of {cr.fit_label} by less "
                   f"than the selection's threshold")
        entry = {"name": name, "estimate": e["estimate"], "ci95": e["ci95"], "unit": e["unit"],
                 "plausible": bool(e["plausible"]),
                 "accepted": bool(accepted), "why": why, "source": "balance",
                 "plausible_range": e["plausible_range"], "on_bound": bool(e["on_bound"])}
        out.append(entry)
    return out


def _mass_entry(total_mass: Mapping) -> dict:
    est = total_mass.get("estimate")
    return {"name": "total_mass", "estimate": est, "ci95": total_mass.get("ci95"), "unit": "kg",
            "plausible": est is not None, "accepted": est is not None,
            "why": None if est is not None else total_mass.get("why"), "source": "energy balance"}


def _drivetrain_entries(drivetrain: Mapping) -> list[dict]:
    out = []
    for name, t in drivetrain.items():
        if name in MASS_NUISANCE or not isinstance(t, dict):
            continue
        est = t.get("estimate")
        lo, hi = DRIVETRAIN_PLAUSIBLE.get(name, (-math.inf, math.inf))
        ok = est is not None and math.isfinite(est) and lo <= est <= hi
        why = t.get("why") if est is None else (None if ok else
                                                f"outside its plausible range {lo:g} to {hi:g}")
        out.append({"name": name, "estimate": est, "ci95": t.get("ci95"), "unit": t.get("unit"),
                    "plausible": bool(ok), "accepted": bool(ok), "why": why, "source": "drivetrain"})
    return out


def _controller_entries(controller: Mapping | None) -> list[dict]:
    if not isinstance(controller, dict) or controller.get("law") is None:
        return []
    return [{"name": f"controller.{t['name']}", "estimate": t.get("estimate"), "ci95": t.get("ci95"),
             "unit": t.get("unit"), "plausible": t.get("estimate") is not None,
             "accepted": t.get("estimate") is not None, "why": None, "source": "controller"}
            for t in controller.get("terms", []) if isinstance(t, dict)]


def parameter_list(cr: CrossRide, total_mass: Mapping, drivetrain: Mapping,
                   controller: Mapping | None = None) -> list[dict]:
    """CONTRACT's ``parameters``: every fitted quantity of the ride once.

    Parameters
    ----------
    cr : CrossRide
        The balance fit (its resistances and losses).
    total_mass, drivetrain, controller : mapping
        The ride JSON's objects (``drivetrain`` before :func:`drivetrain_view`).

    Returns
    -------
    list of dict
        ``{"name", "estimate", "ci95", "unit", "plausible", "accepted", "why",
        "source"}`` (the balance's also ``"on_bound"``: accepted on the edge of its
        plausible range, where the ride asks for more); an accepted entry is plausible.
    """
    return (_balance_entries(cr) + [_mass_entry(total_mass)] + _drivetrain_entries(drivetrain)
            + _controller_entries(controller))


def drivetrain_view(drivetrain: Mapping, parameters) -> dict:
    """The ``drivetrain`` object with C_rr, C_dA, the no-load power and copper loss from ``parameters``.

    The energy balance's coefficients (fitted for the mass, where they also hold
    losses with the same speed law) are dropped; each road and loss term is the
    balance fit's number, marked ``accepted``.
    """
    by = {p["name"]: p for p in parameters}
    out = {k: dict(v) for k, v in drivetrain.items() if k not in MASS_NUISANCE}
    for key, name, f, unit in (("C_rr", "rolling_resistance", 1.0, "dimensionless"),
                               ("C_dA", "aerodynamic_drag", 2.0 / RHO_AIR, "m^2"),
                               ("no_load_power", "drivetrain_idle_loss", 1.0, "W"),
                               ("copper_loss_per_force2", "copper_loss", 1.0, "W/N^2")):
        p = by.get(name)
        if p is None:
            continue
        out[key] = {"estimate": p["estimate"] * f,
                    "ci95": [c * f for c in p["ci95"]] if p["ci95"] else None, "unit": unit,
                    "accepted": p["accepted"], "parameter": name}
        if not p["accepted"]:
            out[key]["why"] = p["why"]
    return out


