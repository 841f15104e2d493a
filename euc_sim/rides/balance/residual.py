"""Where a ride's balance residual concentrates.

:func:`residual_windows` evaluates the fitted inertia-only and augmented
balances (:mod:`euc_sim.rides.balance.fit`) over a whole ride and hands the inertia-only
residual to the diagnosis module's :func:`euc_sim.diagnosis.localise.localise`, which
returns the windows (s) where the mismatch concentrates, as ``euc-sim diagnose``
does for a recording (the page draws them:
:func:`euc_sim.rides.render.fit_figures.residuals_figure`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from euc_sim.diagnosis.localise import Localisation, localise
from euc_sim.rides.balance.design import balance_design
from euc_sim.rides.grids.signals import RideSignals, split_at_gaps

__all__ = ["ResidualTrace", "residual_windows", "WINDOW_SMOOTH", "WINDOW_MIN", "SLOW_S"]

#: localise() settings for rides, s: minutes-long logs at ~5 Hz need a longer
#: smoothing of the residual power and a longer shortest window than its
#: 1 s / 0.5 s defaults (made for 120 Hz motion capture), else the windows
#: fragment into dozens of sub-second pieces.
WINDOW_SMOOTH = 5.0
WINDOW_MIN = 3.0
#: Moving-mean length, s, of the residual's slow part (hills, wind, temperature).
SLOW_S = 30.0


@dataclass(frozen=True)
class ResidualTrace:
    """A ride's balance residual over time under two parameter sets.

    Attributes
    ----------
    label : str
    t : numpy.ndarray
        s, rows the design uses (gaps and segment ends left out).
    nominal, augmented : numpy.ndarray
        Measured − predicted battery power, W (or N·m in the torque domain).
    unit : str
    localisation : Localisation
        Of ``nominal`` (:func:`euc_sim.diagnosis.localise.localise`).
    in_sample : bool
        True when the parameters were fitted on this ride.
    """

    label: str
    t: np.ndarray
    nominal: np.ndarray
    augmented: np.ndarray
    unit: str
    localisation: Localisation
    in_sample: bool

    def slow(self, which: str = "augmented", span: float = SLOW_S) -> np.ndarray:
        """Moving mean of a residual over ``span`` s (same unit), its slow part."""
        r = getattr(self, which)
        dt = float(np.median(np.diff(self.t))) if self.t.size > 1 else 1.0
        w = max(1, min(r.size, int(round(span / dt))))     # "same" keeps r's length
        num = np.convolve(r, np.ones(w), mode="same")
        k = np.arange(r.size) + (w - 1) // 2                # the samples under each window: counted
        return num / (np.minimum(k, r.size - 1) - np.maximum(0, k - w + 1) + 1)



def residual_windows(sig: RideSignals, nominal: Mapping[str, float],
                     augmented: Mapping[str, float], domain: str = "power",
                     label: str | None = None, in_sample: bool = True,
                     smooth: float = WINDOW_SMOOTH, min_len: float = WINDOW_MIN,
                     design=None) -> ResidualTrace:
    """The inertia-only and augmented residuals of a whole ride, and where they concentrate.

    Parameters
    ----------
    sig : RideSignals
    nominal, augmented : mapping
        Fitted parameters (``CrossRide.nominal.estimate``, ``.augmented.estimate``).
    domain : {"power", "torque"}
    label : str, optional
    in_sample : bool
        Whether the parameters were fitted on this ride (reported, not used).
    smooth, min_len : float
        s, passed to :func:`euc_sim.diagnosis.localise.localise`.
    design : Design, optional
        ``balance_design(sig, domain)`` when already built.

    Returns
    -------
    ResidualTrace
        The rows are the design's: uniform 1/rate except across the gaps where
        the ride was split, which ``localise`` (made for uniform sampling) sees
        as adjacent samples; its windows are then cut at those gaps
        (:func:`split_at_gaps`).
    """
    d = design if design is not None else balance_design(sig, domain)
    r_nom = d.residual(nominal)
    r_aug = d.residual(augmented)
    v = d.v
    loc = localise(d.t, r_nom, {"speed": v, "speed_cubed": np.abs(v) ** 3,
                                "inertial_power": d.columns_full["inertia"].to_numpy()[d.use]},
                   smooth=smooth, min_len=min_len)
    loc = dict(loc, windows=split_at_gaps(loc["windows"], d.t, min_len))
    return ResidualTrace(label=label or str(sig.path), t=d.t, nominal=r_nom, augmented=r_aug,
                         unit=d.unit, localisation=loc, in_sample=in_sample)
