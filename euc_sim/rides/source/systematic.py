"""What a ride log cannot calibrate, carried into the total mass's interval.

The block bootstrap (:mod:`euc_sim.rides.drive.mass`) cannot see parts common to
every replicate: ``speed_scale`` (m ∝ 1/k²), ``current_scale`` (m ∝ I, a prior),
``rotating_share`` (J_w/R², :mod:`euc_sim.rides.drive.rotating`), ``efficiency_model``
(κF² vs κa²) and ``grade``.  Each is a 95 % half-width in kg, added in quadrature to
each side of the bootstrap interval.  Priors: docs/drivetrain.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["CURRENT_SCALE_SD", "GRADE_SHARE", "combined_interval", "speed_scale_kg",
           "current_scale_kg", "mass_difference", "SHARED_BY_A_WHEEL"]

#: Systematic parts one wheel shares between its rides: they cancel from a difference.
SHARED_BY_A_WHEEL = ("current_scale", "rotating_share")

#: Relative standard deviation of a wheel's battery-current scale (prior).  Value: see
#: docs/drivetrain.md#figures-that-hold-on-wheels-nobody-tuned-on.
CURRENT_SCALE_SD = 0.10
#: Without GPS altitude: the grade's 95 % half-width as a share of the mass (prior): the
#: median over the shared rides with altitude (0.019; re-chosen per fold likewise).
GRADE_SHARE = 0.02


def speed_scale_kg(mass: float, scale_sd: float) -> float:
    """95 % half-width, kg, of the mass from the speed scale's relative sd (m ∝ 1/k²)."""
    return 1.96 * 2.0 * scale_sd * mass


def current_scale_kg(mass: float, current_sd: float = CURRENT_SCALE_SD) -> float:
    """95 % half-width, kg, of the mass from the current sensor's relative sd (m ∝ I)."""
    return 1.96 * current_sd * mass


def combined_interval(estimate: float, stat_ci95, systematic: dict) -> tuple[float, float] | None:
    """The bootstrap interval ``stat_ci95`` (kg) widened by every systematic half-width in quadrature.

    Returns ``estimate ∓ √((estimate − lo)² + Σ s²)`` or None without a bootstrap interval.
    """
    if stat_ci95 is None:
        return None
    s2 = sum(x * x for x in systematic.values() if x is not None and math.isfinite(x))
    lo, hi = stat_ci95
    below, above = max(estimate - lo, 0.0), max(hi - estimate, 0.0)
    return (estimate - math.sqrt(below ** 2 + s2), estimate + math.sqrt(above ** 2 + s2))


@dataclass(frozen=True)
class MassDifference:
    """The compared ride's total mass minus this one's, kg, with its 95 % interval.

    ``verdict`` is "heavier" (interval above zero: the compared ride carried more), "lighter"
    or "cannot tell"; ``why`` says why there is no estimate; ``cancelled`` the systematic
    parts both rides share.
    """

    estimate: float | None
    ci95: tuple | None
    verdict: str
    why: str | None = None
    cancelled: tuple = ()
    unit: str = "kg"
    note: str = "the compared ride minus this one; 'heavier': the compared ride carried more"


def mass_difference(a, b) -> MassDifference:
    """Total mass of ride ``b`` minus ride ``a`` (two :class:`MassFit` of one wheel), with its 95 % interval.

    Independent parts add in quadrature; :data:`SHARED_BY_A_WHEEL` (and an assumed speed
    scale on both) cancel.
    """
    if a.estimate is None or b.estimate is None or not a.stat_ci95 or not b.stat_ci95:
        which = "this ride" if a.estimate is None else "the compared ride"
        return MassDifference(None, None, "cannot tell", f"the mass of {which} is not identified")
    both_assumed = a.scale.source == "assumed" and b.scale.source == "assumed"
    shared = set(SHARED_BY_A_WHEEL) | ({"speed_scale"} if both_assumed else set())
    s2 = sum(x * x for f in (a, b) for k, x in f.systematic.items()
             if k not in shared and x is not None and math.isfinite(x))
    d = b.estimate - a.estimate
    lo_b, hi_b = b.estimate - b.stat_ci95[0], b.stat_ci95[1] - b.estimate
    lo_a, hi_a = a.estimate - a.stat_ci95[0], a.stat_ci95[1] - a.estimate
    ci = (d - math.sqrt(max(lo_b, 0) ** 2 + max(hi_a, 0) ** 2 + s2),
          d + math.sqrt(max(hi_b, 0) ** 2 + max(lo_a, 0) ** 2 + s2))
    verdict = "heavier" if ci[0] > 0 else "lighter" if ci[1] < 0 else "cannot tell"
    return MassDifference(d, ci, verdict, cancelled=tuple(sorted(shared)))
