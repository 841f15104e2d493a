"""The wheel's rotating inertia, taken out of the mass a ride's energy balance finds.

Battery power balances the change of kinetic energy, and the kinetic energy of
the paper's model (Appendix, eq. 6) is ``½·m_eq·ẋ²`` with

    m_eq = m + m_0 + m_w + J_w/R²                                   # eq. (6), m_11

so the coefficient of ``a·v`` that :func:`euc_sim.rides.drive.mass.fit_mass` estimates
is m_eq, not the rider plus the wheel: the tyre, rim and outer rotor of a hub
motor also store ``½·J_w·(v/R)²``.  A maker's specification gives the net
weight, not J_w, so J_w/R² is taken as a share of the net weight:

- Table 3: J_w/R² = 0.12 kg·m² / (0.2 m)² = 3 kg of a 16 kg EUC, a share of 0.19;
- a hub-motor wheel turns its tyre and rim (a hoop at R) and its outer rotor
  (magnets and shell near 0.6 R): with 25–45 % of the net weight turning,
  J_w/R² is 0.10–0.28 of it, the range carried into the interval.

Without a net weight the correction cannot be made, and the estimate stays m_eq,
said so in ``unidentified``.
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
    """Rider plus wheel from m_eq: subtract J_w/R² estimated from the net weight.

    Parameters
    ----------
    fit : MassFit
        As :func:`euc_sim.rides.drive.mass.fit_mass` returns it (``estimate`` = m_eq, kg).
        Not modified.
    wheel_mass : float or None
        The wheel's net weight, kg (the spec's); None leaves m_eq and says why.

    Returns
    -------
    MassFit
        A copy whose ``estimate`` is m_eq − 0.19·wheel_mass, whose
        ``systematic`` gains ``rotating_share`` (half the share's range,
        0.09·wheel_mass, kg) and whose ``ci95`` is recombined with it
        (:func:`euc_sim.rides.source.systematic.combined_interval`); ``equivalent``
        keeps m_eq, its interval and the J_w/R² subtracted, kg.  ``by_window``
        is shifted by the same J_w/R².
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
