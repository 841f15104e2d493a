"""What a ride log cannot calibrate, carried into the total mass's interval.

The block bootstrap of :mod:`euc_sim.rides.mass` measures how much the mass
moves with the ride's own noise.  It cannot see the parts of the answer that
are the same on every replicate (issue 20):

- ``speed_scale``: m ∝ 1/k², k the true over the logged speed; from GPS with
  its own standard deviation (:func:`euc_sim.rides.power.speed_scale`), else
  1 ± :data:`~euc_sim.rides.power.NO_GPS_SCALE_SD`;
- ``current_scale``: m ∝ the current sensor's scale, which no log calibrates
  (a prior, :data:`CURRENT_SCALE_SD`);
- ``rotating_share``: J_w/R² taken as 0.10–0.28 of the net weight
  (:mod:`euc_sim.rides.rotating`);
- ``efficiency_model``: the mass's change between the copper-loss models
  (κF² and the proxy κa², logs without phase current);
- ``grade``: the mass's change when the GPS-altitude grade term is dropped, or,
  without altitude, a prior share of the mass (:data:`GRADE_SHARE`).

Each is a 95 % half-width in kg; they are added in quadrature to each side of
the bootstrap interval (:func:`combined_interval`).

The two priors are fixed constants, not fitted per ride.  They were set from
the shared rides (``scripts/real_rides_study.py`` re-chooses both from the
other wheels when it scores a wheel, leaving that wheel out).
"""

from __future__ import annotations

import math

__all__ = ["CURRENT_SCALE_SD", "GRADE_SHARE", "combined_interval", "speed_scale_kg",
           "current_scale_kg"]

#: Relative standard deviation of a wheel's battery-current scale (prior).
CURRENT_SCALE_SD = 0.05
#: Without GPS altitude: the grade's 95 % half-width as a share of the mass (prior).
GRADE_SHARE = 0.03


def speed_scale_kg(mass: float, scale_sd: float) -> float:
    """95 % half-width, kg, of the mass from the speed scale's relative sd (m ∝ 1/k²)."""
    return 1.96 * 2.0 * scale_sd * mass


def current_scale_kg(mass: float, current_sd: float = CURRENT_SCALE_SD) -> float:
    """95 % half-width, kg, of the mass from the current sensor's relative sd (m ∝ I)."""
    return 1.96 * current_sd * mass


def combined_interval(estimate: float, stat_ci95, systematic: dict) -> tuple[float, float] | None:
    """The bootstrap interval with every systematic half-width added in quadrature.

    Parameters
    ----------
    estimate : float
        kg.
    stat_ci95 : (lo, hi) or None
        The bootstrap's 95 % interval, kg.
    systematic : dict
        Source -> 95 % half-width, kg.

    Returns
    -------
    (lo, hi) or None
        ``estimate ∓ √((estimate − lo)² + Σ s²)``; always contains ``estimate``.
    """
    if stat_ci95 is None:
        return None
    s2 = sum(x * x for x in systematic.values() if x is not None and math.isfinite(x))
    lo, hi = stat_ci95
    below, above = max(estimate - lo, 0.0), max(hi - estimate, 0.0)
    return (estimate - math.sqrt(below ** 2 + s2), estimate + math.sqrt(above ** 2 + s2))
