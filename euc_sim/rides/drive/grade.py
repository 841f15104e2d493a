"""The road's grade as the battery-power balance sees it, against GPS altitude.

The power the fitted balance leaves unexplained without its grade term is, to first
order, the power of climbing, g·ḣ_implied = (P − P̂_without grade)/m (W/kg); integrated it
gives the altitude the battery says was climbed, drawn against GPS altitude over
distance.  Where they part, the balance misses something along the road or the altitude
is wrong.  The fitted grade term's own altitude (β_h/m)·h_GPS is drawn too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from euc_sim.rides.drive.mass import MassFit, mass_regressors
from euc_sim.rides.grids.power import G, PowerSignals
from euc_sim.stats import label_rows

__all__ = ["GradeProfile", "grade_profile", "V_STILL"]

#: Below this speed, m/s, nothing is climbed: the implied climb rate is taken as 0.
V_STILL = 1.0


@dataclass(frozen=True)
class GradeProfile:
    """GPS altitude and the altitudes the balance implies, on the ride's grid.

    Attributes
    ----------
    distance : numpy.ndarray
        km from the start (nothing across gaps).
    segment : numpy.ndarray
        Segment of each sample (the implied altitude restarts at each).
    gps, implied : numpy.ndarray
        GPS altitude and the balance's, m, each segment started at its GPS altitude.
    fitted : numpy.ndarray or None
        Altitude of the fitted grade term, m; None when the fit kept none.
    rms_m : float
        RMS of implied − GPS altitude, m.
    climb_gps_m, climb_implied_m : float
        Total ascent after a 30 s moving mean, m.
    """

    distance: np.ndarray
    segment: np.ndarray
    gps: np.ndarray
    implied: np.ndarray
    fitted: np.ndarray | None
    rms_m: float
    climb_gps_m: float
    climb_implied_m: float


def _ascent(h: np.ndarray, t: np.ndarray, segment: np.ndarray, span: float = 30.0) -> float:
    """Total ascent, m, of h after a ``span`` s moving mean, segment by segment."""
    total = 0.0
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    w = max(1, int(round(span / dt)))
    for idx in label_rows(segment):
        x = h[idx]
        x = x[np.isfinite(x)]
        if x.size < 2:
            continue
        k = min(w, x.size)
        sm = np.convolve(x, np.ones(k) / k, mode="valid")
        total += float(np.clip(np.diff(sm), 0.0, None).sum())
    return total


def grade_profile(sig: PowerSignals, fit: MassFit, gps_t: np.ndarray,
                  gps_alt: np.ndarray) -> GradeProfile | None:
    """The altitude the fitted balance implies beside the GPS altitude (``gps_t`` s, ``gps_alt`` m);
    None when the mass is not identified or there is no altitude.
    """
    ok_alt = np.isfinite(gps_alt)
    if fit.estimate is None or not fit.signed or ok_alt.sum() < 2:
        return None
    m = fit.coef["inertia"]
    lag = int(round(fit.lag * (1.0 / np.median(np.diff(sig.t)))))
    cols = mass_regressors(sig, lag)
    P_hat = sum(fit.coef[n] * cols[n] for n in fit.coef if n != "grade" and n in cols)
    rate = np.where(np.nan_to_num(sig.v) > V_STILL, (sig.P - P_hat) / (m * G), 0.0)
    rate = np.nan_to_num(rate)                        # filter ends and missing rows: no climb
    h_gps = np.interp(sig.t, gps_t[ok_alt], gps_alt[ok_alt])
    dt = np.r_[0.0, np.diff(sig.t)]
    new_seg = np.r_[True, sig.segment[1:] != sig.segment[:-1]]
    dt[new_seg] = 0.0
    implied, fitted = np.empty_like(h_gps), np.empty_like(h_gps)
    beta = fit.coef.get("grade")
    for idx in label_rows(sig.segment):
        start = h_gps[idx[0]]
        implied[idx] = start + np.cumsum(rate[idx] * dt[idx])
        if beta is not None:
            fitted[idx] = start + beta / m * (h_gps[idx] - start)
    distance = np.cumsum(np.nan_to_num(np.abs(sig.v)) * dt) / 1000.0
    return GradeProfile(distance=distance, segment=sig.segment, gps=h_gps, implied=implied,
                        fitted=fitted if beta is not None else None,
                        rms_m=float(np.sqrt(np.mean((implied - h_gps) ** 2))),
                        climb_gps_m=_ascent(h_gps, sig.t, sig.segment),
                        climb_implied_m=_ascent(implied, sig.t, sig.segment))
