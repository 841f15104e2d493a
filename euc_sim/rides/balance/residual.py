"""Where a ride's balance residual concentrates: :func:`residual_windows` hands the
inertia-only residual over the whole ride to :func:`euc_sim.diagnosis.localise.localise`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from euc_sim.diagnosis.localise import Localisation, localise
from euc_sim.rides.balance.design import Design
from euc_sim.rides.grids.signals import split_at_gaps
from euc_sim.stats import rms

__all__ = ["ResidualTrace", "localise_residual", "residual_windows", "moving_mean", "WINDOW_SMOOTH", "WINDOW_MIN",
           "SLOW_S"]

#: localise() smoothing and shortest window for minutes-long 5 Hz rides, s (its defaults are
#: for 120 Hz motion capture).
WINDOW_SMOOTH = 5.0
WINDOW_MIN = 3.0
#: Moving-mean length, s, of the residual's slow part (hills, wind, temperature).
SLOW_S = 30.0


def moving_mean(t: np.ndarray, r: np.ndarray, span: float = SLOW_S) -> np.ndarray:
    """Moving mean of ``r`` (rows at times ``t``, s) over ``span`` s, each window averaged over the samples it holds."""
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    w = max(1, min(r.size, int(round(span / dt))))     # "same" keeps r's length
    num = np.convolve(r, np.ones(w), mode="same")
    k = np.arange(r.size) + (w - 1) // 2                # the samples under each window: counted
    return num / (np.minimum(k, r.size - 1) - np.maximum(0, k - w + 1) + 1)


@dataclass(frozen=True)
class ResidualTrace:
    """A ride's balance residual over time under two parameter sets.

    ``t`` (s) the design's rows; ``nominal``, ``augmented`` measured − predicted power (W, or
    N·m in the torque domain); ``localisation`` (:class:`~euc_sim.diagnosis.localise.Localisation`)
    of ``nominal``; ``in_sample`` when fitted on this ride; ``slow`` the augmented residual's
    :data:`SLOW_S` s :func:`moving_mean` (hills, wind, temperature; same unit); ``rms_nominal``,
    ``rms_augmented``, ``rms_slow`` their RMS values (same unit), taken when the trace is made.
    """

    label: str
    t: np.ndarray
    nominal: np.ndarray
    augmented: np.ndarray
    unit: str
    localisation: Localisation
    in_sample: bool
    slow: np.ndarray
    rms_nominal: float = field(init=False)
    rms_augmented: float = field(init=False)
    rms_slow: float = field(init=False)

    def __post_init__(self):
        for k in ("nominal", "augmented", "slow"):
            object.__setattr__(self, f"rms_{k}", rms(getattr(self, k)))


def localise_residual(t: np.ndarray, r: np.ndarray, signals: Mapping[str, np.ndarray]) -> Localisation:
    """Where the residual ``r`` (at ``t``, s) concentrates: :func:`~euc_sim.diagnosis.localise.localise`
    against ``signals`` with :data:`WINDOW_SMOOTH` and :data:`WINDOW_MIN`, its windows cut at the
    gaps where the ride was split (:func:`split_at_gaps`)."""
    loc = localise(t, r, signals, smooth=WINDOW_SMOOTH, min_len=WINDOW_MIN)
    return dict(loc, windows=split_at_gaps(loc["windows"], t, WINDOW_MIN))


def residual_windows(d: Design, nominal: Mapping[str, float], augmented: Mapping[str, float], label: str,
                     in_sample: bool) -> ResidualTrace:
    """The inertia-only and augmented residuals of a whole ride's balance design ``d``, and where they
    concentrate (:func:`localise_residual`); ``nominal``, ``augmented``: fitted parameters.
    """
    r_nom = d.residual(nominal)
    r_aug = d.residual(augmented)
    v = d.v
    loc = localise_residual(d.t, r_nom, {"speed": v, "speed_cubed": np.abs(v) ** 3,
                                         "inertial_power": d.columns_full["inertia"].to_numpy()[d.use]})
    return ResidualTrace(label=label, t=d.t, nominal=r_nom, augmented=r_aug,
                         unit=d.unit, localisation=loc, in_sample=in_sample, slow=moving_mean(d.t, r_aug))
