"""The ride JSON's ``controller`` object: :func:`controller_fit` reads the wheel's balance
law from LOG with the drivetrain's K_t = K_e (N·m/A) and predicts a compare ride's phase
current or torque from its pitch (CONTRACT ``heldout``); :func:`controller_entry` is what
the firmware (:mod:`euc_sim.controllers.firmware`) reads.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from euc_sim.rides.grids.law_signals import LawUnavailable, law_rows
from euc_sim.rides.law.controller_law import Law, fit_law, predict, r2

__all__ = ["ControllerFit", "controller_fit", "controller_entry", "torque_constant", "describe", "page_lines",
           "PAPER_PD"]

#: The paper's nominal motor law, N·m/rad and N·m·s/rad (controllers.motor.MotorPD's defaults).
PAPER_PD = {"K_p": 600.0, "K_d": 40.0}


@dataclass(frozen=True)
class ControllerFit:
    """The wheel's balance law read from a ride, or why the log cannot show it.

    Attributes
    ----------
    law : Law or None
    why : str or None
        Why there is no law.
    torque_constant : float or None
        K_t, N·m/A (None: the law is in A of phase current).
    largest_measured : float or None
        The largest |torque| (or current) of the fitted rows.
    heldout_r2, heldout_ride : float, str or None
        R² of the law's prediction on the compared ride's rows (or blocked, within the ride),
        and where it was measured.
    compare_why : str or None
        Why the compared ride could not be predicted.
    """

    law: Law | None
    why: str | None = None
    torque_constant: float | None = None
    largest_measured: float | None = None
    heldout_r2: float | None = None
    heldout_ride: str | None = None
    compare_why: str | None = None


def torque_constant(terms: Mapping | None) -> float | None:
    """K_t, N·m/A: the back-EMF constant (V·s/rad) the drivetrain fit identified, or None.

    ``terms``: the drivetrain's terms by name (:class:`~euc_sim.rides.drive.drivetrain.Term`).
    """
    term = (terms or {}).get("back_emf_constant")
    k = None if term is None else term.estimate
    return float(k) if isinstance(k, (int, float)) and k > 0 else None


def describe(law: Law) -> str:
    """The law in words, beside the paper's PD where it is in N·m."""
    kp, kd = law.terms["K_p"][0], law.terms["K_d"][0]
    u = law.unit
    extra = [n.replace("_", " ") for n in law.names[3:]]
    text = (f"PD on the pitch, K_p = {kp:,.0f} {u}/rad, K_d = {kd:,.0f} {u}·s/rad"
            + (f", with {', '.join(extra)}" if extra else ", nothing catalogued added"))
    if u == "N·m":
        text += (f" (the paper's PD: {PAPER_PD['K_p']:g} and {PAPER_PD['K_d']:g}; "
                 f"K_p {kp / PAPER_PD['K_p']:.1f} times the paper's)")
    return text


def controller_fit(log_path, compare_path=None, k_t: float | None = None,
                   n_boot: int = 100, seed: int = 0) -> ControllerFit:
    """The wheel's balance law read from LOG, with ``k_t`` (N·m/A; without it, in A of phase
    current), and its prediction of COMPARE's current or torque; ``n_boot``, ``seed`` of the
    block bootstrap.
    """
    try:
        rows = law_rows(log_path, k_t)
        law = fit_law(rows, n_boot=n_boot, seed=seed)
    except LawUnavailable as exc:
        return ControllerFit(None, f"{log_path.name}: {exc}")
    out = dict(law=law, torque_constant=k_t, heldout_r2=law.heldout_r2,
               heldout_ride=log_path.name + " (blocked, within the ride)")
    if "torque_limit" in law.terms:     # the fit's clip is a least-squares level, not a bound:
        out["largest_measured"] = float(np.max(np.abs(rows.y)))     # the wheel gave this much
    if compare_path is not None:
        try:
            other = law_rows(compare_path, k_t)
        except LawUnavailable as exc:
            out["compare_why"] = f"{compare_path.name}: {exc}"
        else:
            if other.channel == law.channel:
                out.update(heldout_r2=r2(other.y, predict(other, law.fit)), heldout_ride=compare_path.name)
    return ControllerFit(**out)


def controller_entry(c: ControllerFit) -> dict:
    """CONTRACT's ``controller`` object: what ``euc-sim sim --firmware`` reads
    (:func:`euc_sim.controllers.firmware.firmware_motor`), and the simulated replay with it.

    Returns
    -------
    dict
        ``law`` (str), ``terms`` [{name, estimate, ci95, unit}] (``torque_limit`` also
        ``largest_measured``: the largest |torque| of the fitted rows), ``sign``,
        ``heldout`` {r2, channel, ride}, ``within_ride``, ``selection``; or
        ``{"law": None, "why": str}``.
    """
    law = c.law
    if law is None:
        return {"law": None, "why": c.why}
    out = {"law": describe(law),
           "terms": [{"name": k, "estimate": v, "ci95": list(ci) if ci else None, "unit": u}
                     for k, (v, ci, u) in law.terms.items()],
           "sign": law.sign, "sign_share": law.sign_share,
           "torque_constant": c.torque_constant, "channel": law.channel,
           "within_ride": {"r2": law.heldout_r2, "nominal_r2": law.nominal_r2,
                           "without_pitch_r2": law.blind_r2, "rmse": law.heldout_rmse,
                           "unit": law.unit},
           "selection": law.history,
           "heldout": {"r2": c.heldout_r2, "channel": law.channel, "ride": c.heldout_ride}}
    for term in out["terms"]:
        if term["name"] == "torque_limit":
            term["largest_measured"] = c.largest_measured
    if c.compare_why is not None:
        out["heldout"]["compare_why"] = c.compare_why
    return out


def page_lines(ctrl: dict | None) -> list[str]:
    """The ride page's section on the wheel's balance law (markdown lines)."""
    md = ["## The wheel's balance law", ""]
    if not ctrl or ctrl.get("law") is None:
        md += [f"Not read from this log: {(ctrl or {}).get('why', 'not computed')}.", ""]
        return md
    md += [f"{ctrl['law']}. Logged pitch sign {ctrl['sign']:+d} (forward lean "
           f"{'raises' if ctrl['sign'] > 0 else 'lowers'} the logged tilt).", "",
           "| term | estimate | 95 % | unit |", "|---|---|---|---|"]
    for t in ctrl["terms"]:
        ci = t["ci95"]
        md.append(f"| {t['name']} | {t['estimate']:.4g} | "
                  + (f"{ci[0]:.4g} – {ci[1]:.4g}" if ci else "–") + f" | {t['unit']} |")
    h, w = ctrl["heldout"], ctrl["within_ride"]
    md += ["", f"Held-out R² of the {h['channel']} predicted from the pitch: **{h['r2']:.3f}** "
               f"({h['ride']}); within the fitted ride {w['r2']:.3f} (PD alone {w['nominal_r2']:.3f}, "
               f"speed and acceleration without the pitch {w['without_pitch_r2']:.3f}).", ""]
    return md
