"""The wheel's rotating inertia, taken out of the mass a ride's energy balance finds.

The coefficient of a·v is m_eq = m + m_0 + m_w + J_w/R² (eq. 6, m_11), not rider plus
wheel.  A spec gives the net weight, not J_w, so J_w/R² is a share of it: 0.19 in Table 3
(:data:`ROTATING_SHARE`), 0.10–0.28 for hub-motor wheels (25–45 % of the net weight
turning; :data:`ROTATING_SHARE_RANGE`, carried into the interval).
"""

from __future__ import annotations

import dataclasses

from euc_sim.model.parameters import TABLE3
from euc_sim.rides.drive.mass import MassFit
from euc_sim.rides.source.systematic import combined_interval

__all__ = ["ROTATING_SHARE", "ROTATING_SHARE_RANGE", "without_rotating_inertia"]

#: J_w/R² over the EUC's mass in Table 3 (0.12 / 0.2² / 16 = 0.19).
ROTATING_SHARE = TABLE3.Jw / TABLE3.R ** 2 / (TABLE3.m0 + TABLE3.mw)
#: The range of that share for hub-motor wheels (see the module's docstring).
ROTATING_SHARE_RANGE = (0.10, 0.28)


def without_rotating_inertia(fit: MassFit, wheel_mass: float | None) -> MassFit:
    """Rider plus wheel from m_eq: subtract J_w/R² = :data:`ROTATING_SHARE` × ``wheel_mass`` (kg).

    Returns a copy of ``fit`` with the estimate and ``by_window`` shifted, ``systematic``
    gaining ``rotating_share`` (half the share's range × wheel_mass), ``ci95`` recombined and
    ``equivalent`` keeping m_eq.  Without a net weight, m_eq stays and ``unidentified`` says why.
    """
    if fit.equivalent:
        raise ValueError("fit: the rotating inertia has already been taken out of this mass")
    if wheel_mass is None or fit.estimate is None:
        why = ("no net weight of the wheel: the mass found is m_eq (eq. 6), rider + wheel + the "
               "wheel's rotating inertia J_w/R² (a few kg), which it exceeds")
        return dataclasses.replace(fit, unidentified={**fit.unidentified, "rotating_inertia": why}
                                   ) if fit.estimate is not None else fit
    lo_s, hi_s = ROTATING_SHARE_RANGE
    J_w_R2 = ROTATING_SHARE * wheel_mass
    est = fit.estimate - J_w_R2
    stat = (fit.stat_ci95[0] - J_w_R2, fit.stat_ci95[1] - J_w_R2) if fit.stat_ci95 else None
    systematic = {**fit.systematic, "rotating_share": 0.5 * (hi_s - lo_s) * wheel_mass}
    return dataclasses.replace(
        fit, estimate=est, ci95=combined_interval(est, stat, systematic), stat_ci95=stat,
        systematic=systematic,
        by_window={w: x - J_w_R2 for w, x in fit.by_window.items()},
        equivalent={"estimate": fit.estimate, "ci95": list(fit.ci95) if fit.ci95 else None,
                    "rotating_inertia": J_w_R2, "rotating_inertia_range": [lo_s * wheel_mass, hi_s * wheel_mass]})
