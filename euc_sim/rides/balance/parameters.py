"""The ride's one parameter set: every fitted physical quantity once, with its verdict.

The ride JSON's ``parameters`` (CONTRACT) lists the balance fit's resistances and losses,
the total mass, the battery and motor terms and the balance law's terms once each;
``drivetrain``, ``total_mass``, ``controller`` and ``effects`` are views of it.
:func:`drivetrain_view` makes the drivetrain's road and loss terms repeat the balance
fit's numbers (the energy balance's own are nuisance terms of the mass).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Mapping

from euc_sim.rides.balance.crossride import CrossRide
from euc_sim.rides.balance.design import NOMINAL
from euc_sim.rides.balance.fit import plausibility
from euc_sim.rides.balance.verdict import unit_label
from euc_sim.rides.drive.drivetrain import Term
from euc_sim.rides.grids.power import RHO_AIR

__all__ = ["Parameter", "parameter_list", "effect_estimates", "drivetrain_view",
           "DRIVETRAIN_PLAUSIBLE", "MASS_NUISANCE"]

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


@dataclass(frozen=True)
class Parameter:
    """One fitted quantity of the ride, with its verdict.

    Attributes
    ----------
    name : str
        The contract's name (``rolling_resistance``, ``total_mass``, ``controller.K_p``, ...).
    estimate, ci95 : float, sequence or None
        In ``unit``, with its 95 % interval; None where not identified.
    unit : str or None
    plausible, accepted : bool
        An accepted entry is plausible.
    why : str or None
        Why it is not accepted (or on the edge of its range).
    source : {"balance", "energy balance", "drivetrain", "controller"}
    plausible_range, on_bound : sequence of float, bool or None
        The balance's terms only.
    rmse_after, aliases, evidence, extra : float, tuple of str, str, dict or None
        An accepted effect's (:func:`effect_estimates`): the fit ride's RMS error once it is kept (the
        fit's unit), the terms it cannot be told from, why it is kept, its ``json_extra`` (other units).
    """

    name: str
    estimate: float | None
    ci95: tuple | None
    unit: str | None
    plausible: bool
    accepted: bool
    why: str | None
    source: str
    plausible_range: tuple | None = None
    on_bound: bool | None = None
    rmse_after: float | None = None
    aliases: tuple | None = None
    evidence: str | None = None
    extra: dict | None = None


def _balance_entries(cr: CrossRide) -> list[Parameter]:
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
        out.append(Parameter(name, e["estimate"], e["ci95"], e["unit"], bool(e["plausible"]), bool(accepted),
                             why, "balance", e["plausible_range"], bool(e["on_bound"])))
    return out


def _evidence(cr: CrossRide, name: str, ph: dict, exact: list, confounded: list) -> str:
    """Why ``cr`` keeps ``name`` (``ph``: its :func:`plausibility` entry, with these aliases), in words."""
    step = next((h for h in cr.selection[1:] if name in h["term"].split("+")), None)
    before = cr.selection[max(0, list(cr.selection).index(step) - 1)] if step else None
    ev = (f"adding {ph['symbol']} ({ph['meaning']}) lowers the blocked held-out RMS error "
          f"on {cr.fit_label} from {before['heldout_rmse']:.0f} to {step['heldout_rmse']:.0f} "
          f"{cr.nominal.unit}" if step else f"{ph['symbol']} ({ph['meaning']})")
    ev += f", 95% interval {ph['ci95'][0]:.3g} to {ph['ci95'][1]:.3g} {unit_label(ph['unit'])}"
    if exact:
        ev += (f"; the speed never changes sign, so it is the sum of this and "
               f"{' and '.join(exact)} (a constant road grade looks the same)")
    if confounded:
        ev += (f"; in the fit with every candidate its estimate trades off against "
               f"{' and '.join(confounded)} (bootstrap correlation beyond ±0.8): this ride "
               f"cannot tell them apart")
    if ph["on_bound"]:
        lo, hi = ph["plausible_range"]
        ev += (f"; ON THE EDGE of its plausible range {lo:g} to {hi:g} "
               f"{unit_label(ph['unit'])}: the ride asks for more than plausible "
               f"{ph['symbol']} gives, and something the model lacks supplies the rest")
    if not ph["plausible"]:
        ev += (f"; OUTSIDE the plausible range {ph['plausible_range'][0]:g} to "
               f"{ph['plausible_range'][1]:g} {unit_label(ph['unit'])}: it also absorbs something else")
    return ev


def effect_estimates(cr: CrossRide, parameters) -> tuple[Parameter, ...]:
    """Each effect ``cr`` accepted, in the order kept, with its evidence (the ride JSON's ``effects``),
    from its entry in ``parameters`` (:func:`parameter_list` of ``cr``)."""
    params = {p.name: p for p in parameters}
    phys = plausibility(cr.augmented)
    out = []
    for i, c in enumerate(cr.accepted):
        exact = list(cr.fit_design.aliases.get(c, ()))
        confounded = [x for x in cr.full.confounded(c) if x not in exact]
        extra = {k: phys[c][k] for k in ("drag_area_m2", "drag_area_m2_ci95", "angle_rad") if k in phys[c]}
        out.append(replace(params[c], rmse_after=cr.fit_design_rmse([*NOMINAL, *cr.accepted[:i + 1]]),
                           aliases=tuple(exact + confounded), evidence=_evidence(cr, c, phys[c], exact, confounded),
                           extra=extra))
    return tuple(out)


def _mass_entry(mass) -> Parameter:
    est = None if mass is None else mass.estimate
    return Parameter("total_mass", est, None if mass is None else mass.ci95, "kg", est is not None,
                     est is not None, None if est is not None else getattr(mass, "why", None), "energy balance")


def _drivetrain_entries(terms: Mapping) -> list[Parameter]:
    out = []
    for name, t in terms.items():
        if name in MASS_NUISANCE:
            continue
        est = t.estimate
        lo, hi = DRIVETRAIN_PLAUSIBLE.get(name, (-math.inf, math.inf))
        ok = est is not None and math.isfinite(est) and lo <= est <= hi
        why = t.why if est is None else (None if ok else f"outside its plausible range {lo:g} to {hi:g}")
        out.append(Parameter(name, est, t.ci95, t.unit, bool(ok), bool(ok), why, "drivetrain"))
    return out


def _controller_entries(law) -> list[Parameter]:
    if law is None or law.law is None:
        return []
    return [Parameter(f"controller.{k}", v, ci, u, v is not None, v is not None, None, "controller")
            for k, (v, ci, u) in law.law.terms.items()]


def parameter_list(cr: CrossRide, mass, terms: Mapping, law=None) -> tuple[Parameter, ...]:
    """CONTRACT's ``parameters``: the balance's terms (kept first, then the full fit's), the
    total ``mass`` as reported, the drivetrain's ``terms`` (before :func:`drivetrain_view`)
    and the balance ``law``'s, each once.
    """
    return tuple(_balance_entries(cr) + [_mass_entry(mass)] + _drivetrain_entries(terms)
                 + _controller_entries(law))


def drivetrain_view(terms: Mapping, parameters) -> dict[str, Term]:
    """The drivetrain's terms with C_rr, C_dA, the no-load power and copper loss from ``parameters``.

    The energy balance's coefficients (fitted for the mass, where they also hold
    losses with the same speed law) are dropped; each road and loss term is the
    balance fit's number, marked ``accepted``.

    Returns
    -------
    dict of str -> Term
    """
    by = {p.name: p for p in parameters}
    out = {k: v for k, v in terms.items() if k not in MASS_NUISANCE}
    for key, name, f, unit in (("C_rr", "rolling_resistance", 1.0, "dimensionless"),
                               ("C_dA", "aerodynamic_drag", 2.0 / RHO_AIR, "m^2"),
                               ("no_load_power", "drivetrain_idle_loss", 1.0, "W"),
                               ("copper_loss_per_force2", "copper_loss", 1.0, "W/N^2")):
        p = by.get(name)
        if p is None:
            continue
        out[key] = Term(p.estimate * f, [c * f for c in p.ci95] if p.ci95 else None, unit,
                        why=None if p.accepted else p.why, accepted=p.accepted, parameter=name)
    return out
