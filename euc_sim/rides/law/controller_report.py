"""The ride JSON's ``controller`` object: :func:`controller_fit` reads the wheel's balance
law from LOG with the drivetrain's K_t = K_e (N·m/A) and predicts a compare ride's phase
current or torque from its pitch (CONTRACT ``heldout``; the JSON:
:func:`euc_sim.report.ride.contract.controller_json`); :func:`firmware_terms` hands the law to
the firmware (:mod:`euc_sim.controllers.firmware`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from euc_sim.controllers.firmware import LawTerm
from euc_sim.rides.grids.law_signals import LawUnavailable, law_rows
from euc_sim.rides.law.controller_law import Law, fit_law, predict, r2

__all__ = ["ControllerFit", "controller_fit", "firmware_terms", "torque_constant", "describe", "PAPER_PD"]

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


def firmware_terms(c: ControllerFit) -> dict[str, LawTerm]:
    """The law's terms as the simulator's firmware reads them (:func:`euc_sim.controllers.firmware.firmware_motor`;
    the ride JSON's ``controller`` carries the same); empty without a law."""
    if c.law is None:
        return {}
    return {k: LawTerm(v, ci, u, c.largest_measured if k == "torque_limit" else None)
            for k, (v, ci, u) in c.law.terms.items()}
