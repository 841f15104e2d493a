"""Step 7, the verdict: structure left over, whether the recording can decide, what is named.

A generic periodic basis and the noise floor decide ``unexplained``; detection limits
and h's interval decide whether the recording can decide anything; with structure left
unexplained, only effects that explained most of the mismatch are named.
"""

from __future__ import annotations

import numpy as np

from euc_sim.diagnosis.common import THRESHOLDS, h_at_bound as _h_at_bound, heldout_over_floor
from euc_sim.identification import selection as sel

__all__ = ["leftover", "judge", "cannot_see"]


def leftover(fin, selected, floor_stacked: float) -> dict:
    """Structure left after the selected set: a generic periodic basis against the noise floor.

    ``floor_stacked``: noise floor of all residual rows, N·m.  Returns ``heldout_without``,
    ``heldout_with`` (N·m), ``gain``, ``floor_ratio`` (every selected effect, tentative ones
    too) and ``unexplained``.
    """
    cv_wo, cv_gen = sel.generic_gain(fin.problem, selected, sel.sinusoid_basis(fin.problem.time))
    gain = 1.0 - cv_gen / cv_wo
    ratio = heldout_over_floor(fin.cv, floor_stacked)
    return {"heldout_without": cv_wo, "heldout_with": cv_gen, "gain": gain, "floor_ratio": ratio,
            "unexplained": bool(gain >= THRESHOLDS.generic_gain or ratio >= THRESHOLDS.floor_ratio)}


def _h_notes(fin, h_ok: bool, periodic: bool, h_at_bound: bool) -> list[str]:
    h_se_f = float(np.sqrt(max(fin.cov[-1, -1], 0.0)))
    where = f"h = {fin.fit.h:.2f} m ± {1.96 * h_se_f:.2f} m{', at the search bound' if h_at_bound else ''}"
    if not h_ok and periodic:
        return [f"h is unreliable here ({where}): the structure left unexplained pulls it"]
    if not h_ok:
        return [f"h is not identifiable here ({where}): too little excitation; "
                "a constant force and a wrong h look the same without speed changes"]
    return []


def judge(effects_out: list[dict], cv_nominal: float, fin, limits: dict, vis: dict, left: dict,
          beside_structure: bool = False) -> dict:
    """The verdict, the effects named and those only tentative, and the notes (by :data:`THRESHOLDS`).

    Parameters
    ----------
    effects_out : list of dict
        :func:`euc_sim.diagnosis.estimates.effect_items`, strongest first.
    cv_nominal : float
        Held-out RMSE of the nominal model, N·m.
    fin : refine.Final
    limits, vis, left : dict
        :func:`~euc_sim.diagnosis.estimates.detection_limits`,
        :func:`~euc_sim.diagnosis.candidates.visibility`, :func:`leftover`.
    beside_structure : bool
        The effects were selected beside the periodic structure, so are named beside
        ``unexplained``.

    Returns
    -------
    dict
        ``verdict``, ``effects``, ``tentative``, ``unexplained``, ``decidable``, ``notes``,
        ``cannot_see``.
    """
    unexplained = left["unexplained"]
    detectable = [c for c, v in limits.items() if v["status"] in ("detectable", "only large values")]
    h_se_f = float(np.sqrt(max(fin.cov[-1, -1], 0.0)))      # h with the accepted effects
    h_at_bound = _h_at_bound(fin.fit.h)
    h_ok = (1.96 * h_se_f <= THRESHOLDS.max_h_halfwidth) and not h_at_bound
    periodic = left["gain"] >= THRESHOLDS.generic_gain      # a periodic structure is a finding in itself
    decidable = bool(detectable) and (h_ok or periodic)
    notes = _h_notes(fin, h_ok, periodic, h_at_bound)
    unseen = cannot_see(limits, vis)
    eff_out, tentative = list(effects_out), []
    if unexplained and eff_out and not beside_structure:
        # a wrong name is worse than none: with structure left unexplained, keep only
        # effects that explain most of the mismatch (held-out RMSE at least halved)
        keep_eff = []
        for i, e in enumerate(eff_out):
            before = cv_nominal if i == 0 else eff_out[i - 1]["rmse_after"]
            (keep_eff if e["rmse_after"] <= THRESHOLDS.unexplained_keep * before else tentative).append(e)
        eff_out = keep_eff
        if tentative:
            notes.append("with structure left unexplained, not named (each explained less than half "
                         "of the mismatch): " + ", ".join(e["name"] for e in tentative))
    if not decidable:
        verdict = "too little excitation or too much noise to decide"
        unexplained = False
        tentative += eff_out
        eff_out = []
    elif eff_out:
        verdict = "missing physics found"
    elif unexplained:
        verdict = "structure left that no catalogued effect explains"
    else:
        verdict = "nothing missing" + (" that this recording can reveal" if unseen else "")
    if unexplained and eff_out:
        verdict += "; structure is left that no catalogued effect explains"
    return {"verdict": verdict, "effects": eff_out, "tentative": tentative, "unexplained": unexplained,
            "decidable": decidable, "notes": notes, "cannot_see": unseen}


def cannot_see(limits: dict, vis: dict) -> dict[str, str]:
    """``{effect: why}`` of effects invisible here (a column missing) or whose detection limit lies above their
    plausible range's lower end."""
    out = {}
    for name, lim in limits.items():
        unit = "" if lim["unit"] in ("1", "") else f" {lim['unit']}"
        if lim["detectable_above"] is None:
            out[name] = vis[name]["reason"]
        elif lim["status"] != "detectable":
            what = "a change of the rider's mass" if name == "rider_mass" else "values"
            out[name] = (f"near the noise floor here: only {what} above {lim['detectable_above']:.3g}{unit} "
                         f"could be seen (plausible {lim['plausible'][0]:g} to {lim['plausible'][1]:g}{unit})")
        if lim.get("blind_windows"):
            spans: list[list[float]] = []          # the (overlapping) windows' extent, for people
            for a, b in sorted(lim["blind_windows"]):
                if spans and a <= spans[-1][1]:
                    spans[-1][1] = max(spans[-1][1], b)
                else:
                    spans.append([a, b])
            where = ", ".join(f"{a:.1f}-{b:.1f} s" for a, b in spans)
            out[name] = ((out[name] + "; ") if name in out else "") + (
                f"a drift wholly inside one of the {len(lim['blind_windows'])} windows of "
                f"limits.blind_windows (within {where}) could not be seen at any plausible size "
                f"(up to {lim['plausible'][1]:g} m): ∂r/∂h there follows only the rider's sway")
    return out
